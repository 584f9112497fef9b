// atacom filter: JSON Lines in, safe controls out (schema in src/safety/filter.hpp and the README).
#include <iostream>

#include "src/safety/filter.hpp"
#include "cli/command.hpp"

namespace {

atacom::cli::RegisterCommand reg({"filter",
                                  "project actions with ATACOM: JSON Lines on stdin, one result line per input on stdout",
                                  [](CLI::App& app) -> std::function<int()> {
                                    app.footer("Input/output schema: see the README section 'atacom filter'.");
                                    return [] {
                                      std::ios::sync_with_stdio(false);
                                      const long failed = atacom::run_filter(std::cin, std::cout);
                                      if (failed > 0) {
                                        std::cerr << "atacom filter: " << failed << " line(s) failed\n";
                                        return 1;
                                      }
                                      return 0;
                                    };
                                  }});

}  // namespace
