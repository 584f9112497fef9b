// atacom demo: random exploration of many robots with and without ATACOM.
#include <filesystem>
#include <iostream>

#include "src/experiments/demo.hpp"
#include "src/core/fs_util.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/core/limits.hpp"

namespace {

struct DemoArgs {
  atacom::DemoConfig cfg = atacom::default_demo_config();
  std::string out = "runs/demo";
};

atacom::cli::RegisterCommand register_demo(
    {"demo", "safe exploration demo: many diff-drive robots, random policy, with and without ATACOM",
     [](CLI::App& app) -> std::function<int()> {
       auto args = std::make_shared<DemoArgs>();
       using namespace atacom;
       cli::add_integer_flag(app, "--envs", args->cfg.envs, range::closed(1, limits::kMaxEnvs), "number of robots");
       cli::add_integer_flag(app, "--steps", args->cfg.steps, range::closed(1, limits::kMaxHorizon),
                             "control steps per robot (30 Hz)");
       cli::add_integer_flag(app, "--seed", args->cfg.seed, cli::seed_range<uint64_t>(), "random seed");
       app.add_option("--out", args->out, "directory for summary.json and demo.svg ('' to skip)");
       return [args] {
         const atacom::DemoResult res = atacom::run_demo(args->cfg);
         std::cout << res.summary.dump(2) << std::endl;
         const auto& a = res.summary["atacom"];
         const auto& n = res.summary["no_atacom"];
         std::cerr << "with ATACOM: " << a["collisions"] << " collisions, max constraint "
                   << a["max_constraint"].get<double>() << ", " << static_cast<long>(a["per_s"].get<double>())
                   << " env-steps/s\nwithout:     " << n["collisions"] << " collisions\n";
         if (!args->out.empty()) {
           std::filesystem::create_directories(args->out);
           atacom::write_file_atomic(args->out + "/summary.json", res.summary.dump(2) + "\n");
           atacom::write_file_atomic(args->out + "/demo.svg", res.svg);
           std::cerr << "wrote " << args->out << "/summary.json and " << args->out << "/demo.svg\n";
         }
         return 0;
       };
     }});

}  // namespace
