// The `--policy random|zero|la|trained [--run DIR] [--which final|best]` of
// `atacom rollout` and `atacom render`, resolved in one place: which env
// acts (a trained policy brings its run's env, env config and safety
// layer), and the policy for that env's spec.
#pragma once
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/policy.hpp"
#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"

namespace atacom {

struct PolicyRequest {
  std::string policy = "random";  // random | zero | la (the env's linear attractor) | trained (run_dir's)
  std::string env;                // required, except with "trained" (then, if set, it must be the run's)
  std::string run_dir;            // "trained" only
  RunPolicy which = RunPolicy::Final;
  std::optional<SafetyLayer> safety;  // unset: ATACOM, or the run's layer for a trained policy
  nlohmann::json env_config = nlohmann::json::object();  // overrides of the env's defaults (not with "trained")
};

struct PolicySource {
  std::string env;
  nlohmann::json env_config;
  SafetyLayer safety = SafetyLayer::Atacom;
  nlohmann::json safety_params = nullptr;  // the layer's parameters (null: its defaults for the env)
  std::unique_ptr<TrainedPolicy> trained;  // set for "trained"

  // The policy acting on an env of `spec` (built from this source): the
  // trained one, or a new hand-coded one. Throws std::invalid_argument when
  // its dims do not fit the spec.
  Policy& bind(const EnvSpec& spec);

 private:
  friend PolicySource resolve_policy_source(const PolicyRequest& request);
  std::string kind_;
  std::unique_ptr<Policy> own_;
};

// Throws std::invalid_argument for a setting that does not apply (--run
// without "trained", overrides or another env with "trained", no env, an
// unknown policy) and std::runtime_error for an unreadable run.
PolicySource resolve_policy_source(const PolicyRequest& request);

}  // namespace atacom
