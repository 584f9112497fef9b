// One batched policy contract for every action source: hand-coded policies
// (random, zero, an env family's linear attractor) and learned ones (a run
// directory's final or best policy, train/run_policy.cpp) alike. `atacom
// train`, `rollout`, `shelf-real`, `attack` and evaluate() act through it.
//
// A policy maps raw env observations to actions in the env's normalised box:
// put a safety layer between it and the env (wrap_safety) and the same
// policy acts through ATACOM or SafeLayer: the linear attractor becomes
// LA-ATACOM without a line of its own.
#pragma once
#include <iosfwd>
#include <memory>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "atacom/rng.hpp"

namespace atacom {

class Policy {
 public:
  virtual ~Policy() = default;
  virtual int obs_dim() const = 0;
  virtual int act_dim() const = 0;
  // What acts: "random", "zero", "attractor", "sac", ... (file manifests, messages).
  virtual std::string kind() const = 0;
  // obs: (N x obs_dim) raw env observations; actions: (N x act_dim) written,
  // each in [-1, 1]. deterministic: the mean (or only) action; otherwise row
  // i draws its noise from rngs[i], so results do not depend on how a caller
  // splits N. A policy without a mean action (random) samples either way.
  // rngs may be nullptr for policies that draw nothing.
  virtual void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) = 0;
  // Parameters for policy files (not scratch); hand-coded policies have none.
  virtual void save(std::ostream& /*out*/) const {}
  virtual void load(std::istream& /*in*/) {}
};

// alpha ~ U[-1, 1]^act_dim per row from rngs[i] (required), whatever `deterministic` says.
std::unique_ptr<Policy> make_random_policy(int obs_dim, int act_dim);
// alpha = 0: the env's rest action (under ATACOM: the pure correction).
std::unique_ptr<Policy> make_zero_policy(int obs_dim, int act_dim);
// The env family's linear attractor (EnvEntry::make_attractor) for a
// resolved env config. Throws std::invalid_argument naming the envs that
// have one when `env` has none.
std::unique_ptr<Policy> make_attractor_policy(const std::string& env, const nlohmann::json& resolved_env_config);

}  // namespace atacom
