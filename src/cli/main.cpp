// atacom: safe robot RL on CPU. One executable, one subcommand per job.
#include <algorithm>
#include <exception>
#include <iostream>

#include "atacom/parallel.hpp"
#include "cli/command.hpp"

namespace atacom::cli {
std::vector<Command>& commands() {
  static std::vector<Command> all;
  return all;
}
}  // namespace atacom::cli

int main(int argc, char** argv) {
  using namespace atacom::cli;
  CLI::App app{"atacom: safe reinforcement learning on the tangent space of the constraint manifold"};
  app.require_subcommand(1);
  int threads = 0;
  app.add_option("--threads", threads, "worker threads (0 = all cores)")->check(CLI::NonNegativeNumber);
  auto& cmds = commands();
  std::sort(cmds.begin(), cmds.end(), [](const Command& a, const Command& b) { return a.name < b.name; });
  std::vector<std::pair<CLI::App*, std::function<int()>>> runners;
  for (auto& c : cmds) {
    CLI::App* sub = app.add_subcommand(c.name, c.help);
    runners.emplace_back(sub, c.setup(*sub));
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    atacom::set_num_threads(threads);
    for (auto& [sub, run] : runners)
      if (sub->parsed()) return run();
  } catch (const std::exception& e) {
    std::cerr << "atacom: error: " << e.what() << "\n";
    return 2;
  }
  return 1;
}
