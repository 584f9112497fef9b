// `atacom rollout`: run any registered env with a fixed policy, with or
// without ATACOM, and count what matters for safety: ground-truth
// collisions, constraint violations (a row above its stated tolerance) and
// the largest constraint value. Users run it to check that a constraint
// setup is safe before spending hours training.
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom {

struct RolloutConfig {
  std::string env = "nav";
  std::string policy = "random";  // random: alpha ~ U[-1, 1]^m each step; zero: alpha = 0
  bool atacom = true;
  long steps = 100000;            // env steps in total (over all envs)
  int envs = 256;
  uint64_t seed = 0;
  nlohmann::json env_config = nlohmann::json::object();  // overrides of the env's defaults
};

// Returns {"env", "policy", "atacom", "steps", "episodes", "collisions",
// "violations", "max_constraint", "per_s", ...}: every info column whose name
// ends in "collision" is also summed as "<name>s" (e.g. wall_collisions).
// Throws std::invalid_argument for bad input (unknown env/policy, N < 1, ...).
nlohmann::json run_rollout(const RolloutConfig& config);

}  // namespace atacom
