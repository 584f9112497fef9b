// atacom filter: JSON Lines in, safe controls out (schema in src/safety/filter.hpp and the README).
#include <iostream>

#include "src/safety/filter.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/core/limits.hpp"

namespace {

atacom::cli::RegisterCommand register_filter({"filter",
                                  "project actions with ATACOM: JSON Lines on stdin, one result line per input on stdout",
                                  [](CLI::App& app) -> std::function<int()> {
                                    app.footer("Input/output schema: see the README section 'atacom filter'.");
                                    auto max_line = std::make_shared<int64_t>(atacom::limits::kFilterDefaultLineBytes);
                                    atacom::cli::add_integer_flag(
                                        app, "--max-line-bytes", *max_line,
                                        atacom::range::closed<int64_t>(1, atacom::limits::kFilterMaxLineBytes),
                                        "longest input line; a longer one gets an error answer");
                                    return [max_line] {
                                      std::ios::sync_with_stdio(false);
                                      const long failed = atacom::run_filter(std::cin, std::cout, size_t(*max_line));
                                      if (failed > 0) {
                                        std::cerr << "atacom filter: " << failed << " line(s) failed\n";
                                        return 1;
                                      }
                                      return 0;
                                    };
                                  }});

}  // namespace
