// `atacom rollout`: run any registered env with a policy (random, zero, the
// env's linear attractor, or a training run's policy), through a safety
// layer or none, and count what matters for safety: ground-truth
// collisions, constraint violations (a row above its tolerance) and the
// largest constraint value. Users run it to check that a constraint setup
// is safe before spending hours training, and to check a trained policy.
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"

namespace atacom {

struct RolloutConfig {
  std::string env;                // required, except with policy "trained" (then, if set, it must be the run's)
  std::string policy = "random";  // random: alpha ~ U[-1, 1]^m; zero: alpha = 0; la: the env's attractor;
                                  // trained: run_dir's policy (deterministic)
  // The layer between policy and env; unset: ATACOM, or the run's layer for a trained policy.
  std::optional<SafetyLayer> safety;
  std::string run_dir;            // policy "trained" only
  RunPolicy which = RunPolicy::Final;
  long steps = 100000;            // env steps in total (over all envs)
  int envs = 256;
  uint64_t seed = 0;
  nlohmann::json env_config = nlohmann::json::object();  // overrides of the env's defaults (not with "trained")
};

// Returns {"env", "policy", "safety", "atacom" (safety == atacom), "envs",
// "seed", "threads", "steps", "episodes", "terminations", "collisions",
// "violations", "max_constraint", "nonfinite_constraints", "wall_s",
// "per_s", ...}: every contact column (InfoRole) is also summed as "<name>s"
// (e.g. wall_collisions), every episode-event column as its episodes (spills); with a trained policy also
// "run", "run_algo", "run_safety". Throws std::invalid_argument for bad
// input (unknown env/policy, N < 1, a setting that does not apply, ...).
nlohmann::json run_rollout(const RolloutConfig& config);

}  // namespace atacom
