// atacom shelf-real: the ShelfEnvReal protocol (two sequential targets in the
// shelf, success = within 10 cm for 2 s, at most 16.67 s per target) with any
// policy; prints one JSON object with the paper's table columns.
#include <iostream>
#include <memory>

#include "atacom/env_registry.hpp"
#include "atacom/trainer.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/shelf_real.hpp"
#include "src/safety/cbf_env.hpp"

namespace atacom::cli {
namespace {

struct Options {
  std::string policy = "la";
  std::string atacom, safety, which = "final";
  int trials = 25;
  uint64_t seed = 0;
  std::string config_file;
  std::string run_dir;  // --policy trained: the training run to load
  CLI::Option *o_atacom = nullptr, *o_safety = nullptr;
};

int run(const Options& o) {
  const bool trained = o.policy == "trained";
  if (!trained && !o.run_dir.empty())
    throw std::invalid_argument("--run applies to --policy trained only (the policy is '" + o.policy + "')");
  if (!trained && o.which != "final") throw std::invalid_argument("--which applies to --policy trained only");
  if (trained && !o.config_file.empty())
    throw std::invalid_argument("--config does not apply to --policy trained: the run's env config is used");
  if (o.o_atacom->count() && o.o_safety->count() && (o.atacom == "on") != (o.safety == "atacom"))
    throw std::invalid_argument("--atacom " + o.atacom + " contradicts --safety " + o.safety);
  std::optional<SafetyLayer> layer;
  if (o.o_safety->count()) layer = parse_safety_layer(o.safety);
  else if (o.o_atacom->count()) layer = o.atacom == "on" ? SafetyLayer::Atacom : SafetyLayer::None;

  ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
  if (!o.config_file.empty()) from_json(merge_config_strict(nlohmann::json(ec), read_json_file(o.config_file)), ec);
  ShelfRealConfig c = default_shelf_real_config();
  c.trials = o.trials;
  c.seed = o.seed;
  c.layer = parse_shelf_real_layer(layer.value_or(SafetyLayer::Atacom).name());
  std::unique_ptr<Policy> policy;
  nlohmann::json run_info;
  if (trained) {
    if (o.run_dir.empty()) throw std::invalid_argument("--policy trained needs --run DIR (a training run directory)");
    auto tp = TrainedPolicy::load(o.run_dir, o.which == "best" ? RunPolicy::Best : RunPolicy::Final);
    const TrainConfig& t = tp->config().train;
    if (t.env != "shelf") throw std::invalid_argument("run '" + o.run_dir + "' trained env '" + t.env + "', not shelf");
    // The protocol uses the run's env settings and, unless told otherwise, its layer.
    from_json(merge_config_strict(nlohmann::json(ec), tp->config().env), ec);
    c.layer = parse_shelf_real_layer(layer.value_or(tp->safety()).name());
    // CBF's gamma: the run's own when it trained through CBF, else the layer's default.
    if (tp->safety().name() == "cbf") c.cbf_gamma = tp->config().safety.value("gamma", kCbfDefaultGamma);
    run_info = {{"run", o.run_dir}, {"run_algo", t.algo}, {"run_safety", safety_layer_name(tp->safety())},
                {"run_policy", run_policy_file(o.which == "best" ? RunPolicy::Best : RunPolicy::Final)}};
    policy = std::move(tp);
  } else if (o.policy == "la") {
    policy = std::make_unique<ArmAttractorPolicy>(ec);
  } else if (o.policy == "zero") {
    policy = make_zero_policy(kArmObsDim, kArmJoints);
  } else {
    policy = make_random_policy(kArmObsDim, kArmJoints);
  }
  const ShelfRealResult r = evaluate_shelf_real(ec, c, *policy);
  nlohmann::json out = r;
  out["policy"] = o.policy;
  out["safety"] = shelf_real_layer_name(c.layer);
  for (auto it = run_info.begin(); it != run_info.end(); ++it) out[it.key()] = it.value();
  out["protocol"] = c;
  std::cout << out.dump() << "\n";
  return 0;
}

const RegisterCommand register_shelf_real{{"shelf-real",
                           "ShelfEnvReal protocol: two sequential shelf targets per trial, paper's table columns",
                           [](CLI::App& app) -> std::function<int()> {
                             auto o = std::make_shared<Options>();
                             app.add_option("--policy", o->policy,
                                            "la (linear attractor), zero, random, or trained (with --run)")
                                 ->check(CLI::IsMember({"la", "zero", "random", "trained"}));
                             app.add_option("--run", o->run_dir,
                                            "training run directory of a shelf policy (--policy trained)");
                             app.add_option("--which", o->which, "final | best: the run's policy file (--policy trained)")
                                 ->check(CLI::IsMember({"final", "best"}));
                             o->o_safety = app.add_option("--safety", o->safety,
                                                          "none | atacom | safelayer | cbf: the layer between the "
                                                          "policy and the arm (default atacom; with --policy trained "
                                                          "the run's, and a CBF run's gamma; else cbf's gamma 10)")
                                               ->check(CLI::IsMember({"none", "atacom", "safelayer", "cbf"}));
                             o->o_atacom = app.add_option("--atacom", o->atacom, "on | off: the same as --safety atacom | none")
                                               ->check(CLI::IsMember({"on", "off"}));
                             add_integer_flag(app, "--trials", o->trials, range::closed(1, limits::kMaxShelfTrials),
                                              "trials (one env each)");
                             add_integer_flag(app, "--seed", o->seed, seed_range<uint64_t>(), "seed of starts and targets");
                             app.add_option("--config", o->config_file, "JSON file with shelf env config overrides");
                             return [o] { return run(*o); };
                           }}};

}  // namespace
}  // namespace atacom::cli
