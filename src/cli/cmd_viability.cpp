// atacom viability: the ATACOM rollout of `atacom rollout`, with every
// violating step written down and classified (train/viability_audit.hpp).
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "train/viability_audit.hpp"

namespace {

struct ViabilityArgs {
  atacom::ViabilityAuditConfig cfg;
  std::string config_file, bounds;
};

int run(ViabilityArgs& a) {
  if (!a.config_file.empty()) a.cfg.rollout.env_config = atacom::cli::read_json_file(a.config_file);
  if (!a.bounds.empty()) a.cfg.bounds = atacom::parse_bound_rule(a.bounds);
  std::cout << atacom::run_viability_audit(a.cfg).dump() << std::endl;
  return 0;
}

atacom::cli::RegisterCommand register_viability(
    {"viability",
     "run an env through ATACOM with a random, zero or linear-attractor policy and write down every violating step: "
     "its rows, the correction, the saturated bound, and whether any action in the box would have kept the rows",
     [](CLI::App& app) -> std::function<int()> {
       auto a = std::make_shared<ViabilityArgs>();
       app.add_option("--env", a->cfg.rollout.env, "environment name")->required();
       app.add_option("--policy", a->cfg.rollout.policy, "random | zero | la (the env's linear attractor)")
           ->check(CLI::IsMember({"random", "zero", "la"}));
       app.add_option("--bounds", a->bounds, "tangent_scale | correction_first (default: the env's)")
           ->check(CLI::IsMember({"tangent_scale", "correction_first"}));
       app.add_option("--csv", a->cfg.csv, "write one line per violating step to this file");
       using atacom::range::closed;
       namespace lim = atacom::limits;
       atacom::cli::add_integer_flag(app, "--steps", a->cfg.rollout.steps, closed<long>(1, lim::kMaxSteps),
                                     "env steps in total");
       atacom::cli::add_integer_flag(app, "--envs", a->cfg.rollout.envs, closed(1, lim::kMaxEnvs), "parallel envs");
       atacom::cli::add_integer_flag(app, "--seed", a->cfg.rollout.seed, atacom::cli::seed_range<uint64_t>(),
                                     "random seed");
       atacom::cli::add_integer_flag(app, "--max-records", a->cfg.max_records, closed<long>(0, 100000000),
                                     "CSV lines at most");
       app.add_option("--config", a->config_file, "JSON file with env config overrides");
       return [a] { return run(*a); };
     }});

}  // namespace
