// atacom rollout: check a safety setup (or a trained policy) before training.
#include <iostream>

#include "atacom/env_registry.hpp"
#include "atacom/safety_layer.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "train/rollout.hpp"

namespace {

struct RolloutArgs {
  atacom::RolloutConfig cfg;
  std::string atacom, safety, config_file, which = "final", sdf;
  CLI::Option *o_atacom = nullptr, *o_safety = nullptr;
};

int run(RolloutArgs& a) {
  // --atacom on|off is the older spelling of --safety atacom|none.
  if (a.o_atacom->count() && a.o_safety->count() &&
      (a.atacom == "on") != (a.safety == "atacom"))
    throw std::invalid_argument("--atacom " + a.atacom + " contradicts --safety " + a.safety);
  if (a.o_safety->count()) a.cfg.safety = atacom::parse_safety_layer(a.safety);
  else if (a.o_atacom->count()) a.cfg.safety = a.atacom == "on" ? atacom::SafetyLayer::Atacom : atacom::SafetyLayer::None;
  if (!a.config_file.empty()) {
    if (a.cfg.policy == "trained")
      throw std::invalid_argument("--config does not apply to --policy trained: the run's env config is used");
    a.cfg.env_config = atacom::cli::read_json_file(a.config_file);
  }
  if (!a.sdf.empty()) {
    if (a.cfg.policy == "trained")
      throw std::invalid_argument("--sdf does not apply to --policy trained: the run's env config is used");
    if (a.cfg.env_config.is_null()) a.cfg.env_config = nlohmann::json::object();
    a.cfg.env_config.merge_patch(atacom::sdf_flag_override(a.cfg.env, a.sdf));
  }
  if (a.which != "final" && a.cfg.policy != "trained")
    throw std::invalid_argument("--which applies to --policy trained only");
  a.cfg.which = a.which == "best" ? atacom::RunPolicy::Best : atacom::RunPolicy::Final;
  std::cout << atacom::run_rollout(a.cfg).dump() << std::endl;
  return 0;
}

atacom::cli::RegisterCommand register_rollout(
    {"rollout",
     "run an env with a random, zero, linear-attractor or trained policy, through a safety layer or none, and count "
     "collisions and violations",
     [](CLI::App& app) -> std::function<int()> {
       auto a = std::make_shared<RolloutArgs>();
       app.add_option("--env", a->cfg.env, "env: " + [] {
         std::string s;
         for (const std::string& n : atacom::env_names()) s += (s.empty() ? "" : ", ") + n;
         return s;
       }() + " (required unless --policy trained)");
       app.add_option("--policy", a->cfg.policy, "random | zero | la (the env's linear attractor) | trained (with --run)")
           ->check(CLI::IsMember({"random", "zero", "la", "trained"}));
       app.add_option("--run", a->cfg.run_dir, "training run directory (--policy trained)");
       app.add_option("--which", a->which, "final | best: the run's policy file (--policy trained)")
           ->check(CLI::IsMember({"final", "best"}));
       a->o_safety = app.add_option("--safety", a->safety,
                                    atacom::cli::safety_choices() + " (default atacom; with --policy trained the run's)")
                         ->check(CLI::IsMember(atacom::safety_layer_names()));
       a->o_atacom = app.add_option("--atacom", a->atacom, "on | off: the same as --safety atacom | none")
                         ->check(CLI::IsMember({"on", "off"}));
       using atacom::range::closed;
       namespace lim = atacom::limits;
       atacom::cli::add_integer_flag(app, "--steps", a->cfg.steps, closed<long>(1, lim::kMaxSteps), "env steps in total");
       atacom::cli::add_integer_flag(app, "--envs", a->cfg.envs, closed(1, lim::kMaxEnvs), "parallel envs");
       atacom::cli::add_integer_flag(app, "--seed", a->cfg.seed, atacom::cli::seed_range<uint64_t>(), "random seed");
       app.add_option("--config", a->config_file, "JSON file with env config overrides");
       app.add_option("--sdf", a->sdf, "analytic | learned: the distance fields of every object with a shipped model")
           ->check(CLI::IsMember({"analytic", "learned"}));
       return [a] {
         if (a->cfg.env.empty() && a->cfg.policy != "trained")
           throw std::invalid_argument("--env is required (unless --policy trained)");
         return run(*a);
       };
     }});

}  // namespace
