// atacom shelf-real: the ShelfEnvReal protocol (two sequential targets in the
// shelf, success = within 10 cm for 2 s, at most 16.67 s per target) with a
// built-in policy; prints one JSON object with the paper's table columns.
#include <iostream>
#include <memory>

#include "atacom/env_registry.hpp"
#include "atacom/rng.hpp"
#include "envs/arm/shelf_real.hpp"
#include "atacom/trainer.hpp"
#include "cli/command.hpp"

namespace atacom::cli {
namespace {

struct Options {
  std::string policy = "la";
  std::string atacom = "on";
  int trials = 25;
  uint64_t seed = 0;
  std::string config = "{}";
  std::string run_dir;  // --policy trained: the training run to load
  bool atacom_set = false;
};

int run(const Options& o) {
  ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
  from_json(merge_config_strict(nlohmann::json(ec), nlohmann::json::parse(o.config)), ec);
  ShelfRealConfig c = default_shelf_real_config();
  c.trials = o.trials;
  c.seed = o.seed;
  c.atacom = o.atacom == "on";
  BatchPolicy policy;
  if (o.policy == "trained") {
    if (o.run_dir.empty()) throw std::invalid_argument("--policy trained needs --run DIR (a training run directory)");
    std::shared_ptr<TrainedPolicy> tp = TrainedPolicy::load(o.run_dir);
    const TrainConfig& t = tp->config().train;
    if (t.env != "shelf")
      throw std::invalid_argument("run '" + o.run_dir + "' trained env '" + t.env + "', not shelf");
    // The protocol uses the run's env settings, and ATACOM exactly as in training.
    from_json(merge_config_strict(nlohmann::json(ec), tp->config().env), ec);
    c.atacom = t.algo == "atacom-sac";
    policy = [tp](const float* obs, int N, double* a) { tp->act(obs, N, a); };
  } else if (o.policy == "la") {
    ArmEnv probe(ec, 1);
    policy = make_linear_attractor_policy(probe);
  } else if (o.policy == "zero") {
    policy = [](const float*, int N, double* a) { std::fill(a, a + static_cast<size_t>(N) * kArmJoints, 0.0); };
  } else {
    auto rng = std::make_shared<Rng>(o.seed, 7);
    policy = [rng](const float*, int N, double* a) {
      for (size_t i = 0; i < static_cast<size_t>(N) * kArmJoints; ++i) a[i] = rng->uniform(-1.0, 1.0);
    };
  }
  if (o.policy == "trained" && o.atacom_set)
    std::cerr << "shelf-real: --atacom is taken from the run (" << (c.atacom ? "on" : "off") << ")\n";
  const ShelfRealResult r = evaluate_shelf_real(ec, c, policy);
  nlohmann::json out = r;
  out["policy"] = o.policy;
  if (!o.run_dir.empty()) out["run"] = o.run_dir;
  out["protocol"] = c;
  std::cout << out.dump() << "\n";
  return 0;
}

const RegisterCommand reg{{"shelf-real",
                           "ShelfEnvReal protocol: two sequential shelf targets per trial, paper's table columns",
                           [](CLI::App& app) -> std::function<int()> {
                             auto o = std::make_shared<Options>();
                             app.add_option("--policy", o->policy,
                                            "la (linear attractor), zero, random, or trained (with --run)")
                                 ->check(CLI::IsMember({"la", "zero", "random", "trained"}));
                             app.add_option("--run", o->run_dir,
                                            "training run directory of a shelf policy (atacom train --env shelf)");
                             auto* at = app.add_option("--atacom", o->atacom, "ATACOM between policy and env")
                                 ->check(CLI::IsMember({"on", "off"}));
                             app.add_option("--trials", o->trials, "trials (one env each)")->check(CLI::PositiveNumber);
                             app.add_option("--seed", o->seed, "seed of starts and targets");
                             app.add_option("--config", o->config, "JSON overrides of the shelf env config");
                             return [o, at] {
                               o->atacom_set = at->count() > 0;
                               return run(*o);
                             };
                           }}};

}  // namespace
}  // namespace atacom::cli
