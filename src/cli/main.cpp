// atacom: safe robot RL on CPU. One executable, one subcommand per job.
#include <algorithm>
#include <exception>
#include <cstdio>
#include <iostream>

#include "atacom/parallel.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/core/limits.hpp"

namespace atacom::cli {
std::vector<Command>& commands() {
  static std::vector<Command> all;
  return all;
}
}  // namespace atacom::cli

namespace {

// Everything printed reached stdout: a failed write or flush (a full disk,
// /dev/full, a closed pipe) is an error exit, never a silent 0.
bool stdout_written() {
  std::cout.flush();
  const bool ok = std::cout.good() && std::fflush(stdout) == 0 && !std::ferror(stdout);
  if (!ok) std::cerr << "atacom: error: cannot write to stdout (output lost)\n";
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace atacom::cli;
  CLI::App app{"atacom: safe reinforcement learning on the tangent space of the constraint manifold"};
  app.require_subcommand(1);
  app.option_defaults()->always_capture_default();  // --help shows every default (subcommands inherit it)
  int threads = 0;
  add_integer_flag(app, "--threads", threads, atacom::range::closed(0, atacom::limits::kMaxThreads),
                   "worker threads (0 = all cores; more than the cores are clamped to them)");
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
    // --help and --version exit 0; every usage error (an unknown flag, a value
    // out of range, a missing option) exits 2, like every other input error.
    const int rc = app.exit(e) == 0 ? 0 : 2;
    return stdout_written() ? rc : 2;
  }
  int rc = 1;
  try {
    atacom::set_num_threads(0);
    const int cores = atacom::num_threads();
    if (threads > cores) {
      // More TBB workers than cores never run at once; say so instead of echoing a count that is not used.
      std::cerr << "atacom: --threads " << threads << " is more than the " << cores << " cores here; using " << cores
                << "\n";
      threads = cores;
    }
    atacom::set_num_threads(threads);
    for (auto& [sub, run] : runners)
      if (sub->parsed()) {
        rc = run();
        break;
      }
  } catch (const std::exception& e) {
    std::cerr << "atacom: error: " << e.what() << "\n";
    rc = 2;
  }
  return stdout_written() ? rc : 2;
}
