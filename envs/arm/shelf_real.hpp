// ShelfEnvReal protocol (paper, "Real Robot Validation") as an evaluation
// mode of the shelf env: every trial starts from a random safe configuration
// and reaches two targets one after the other. A target succeeds once the
// grasping frame stays within success_radius of it for hold_time; each target
// has at most max_time_per_target. Reported per target, as in the paper's
// table: final error, success rate, collisions and time.
//
// Trials run as a batch of envs (one env per trial). Any Policy (a run's
// trained policy, the arm's linear attractor, random, zero) is evaluated
// with its deterministic action (trial i's noise, for policies that draw,
// from stream (seed, 7 << 32 | i)) through the layer it trained with,
// exactly as in training: the ATACOM projector on alpha, or the SafeLayer /
// CBF QP (include/atacom/safelayer.hpp) on the same rows, or none.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/policy.hpp"
#include "envs/arm/arm_env.hpp"

namespace atacom {

// The layer between the policy and the arm ("none", "atacom", "safelayer",
// "cbf": the safety layers' names).
enum class ShelfRealLayer { None, Atacom, SafeLayer, Cbf };
const char* shelf_real_layer_name(ShelfRealLayer layer);
// Throws std::invalid_argument naming the allowed names for any other.
ShelfRealLayer parse_shelf_real_layer(const std::string& name);

struct ShelfRealConfig {
  int trials = 25;                     // the paper ran 25
  int targets = 2;
  double success_radius = 0.10;        // m
  double hold_time = 2.0;              // s inside the radius to count as success
  double max_time_per_target = 16.67;  // s
  ShelfRealLayer layer = ShelfRealLayer::Atacom;
  double cbf_gamma = 10.0;             // 1/s, layer cbf only (the cbf layer's default gamma)
  uint64_t seed = 0;
};
ShelfRealConfig default_shelf_real_config();
void to_json(nlohmann::json& j, const ShelfRealConfig& c);

struct ShelfRealTarget {
  double final_error_mean = 0.0, final_error_std = 0.0;  // m, at the end of the phase, over trials that started it
  double success_rate = 0.0;                             // over all trials (a crashed trial fails what is left)
  int collisions = 0;                                    // trials that hit something during this target
  double time_mean = 0.0, time_std = 0.0;                // s until success, over successful trials
};

struct ShelfRealResult {
  std::vector<ShelfRealTarget> targets;
  int trials = 0;
  int total_collisions = 0;
  int max_constraint_violations = 0;  // env-steps with a row above its tolerance
};
void to_json(nlohmann::json& j, const ShelfRealResult& r);

// Runs the protocol on a shelf env built from env_config (its horizon is
// raised to cover all targets). Throws std::invalid_argument on bad settings
// or a policy that does not fit the arm (16 observations, 7 actions).
// The arm's linear attractor is ArmAttractorPolicy (envs/arm/arm_attractor.hpp).
ShelfRealResult evaluate_shelf_real(const ArmEnvConfig& env_config, const ShelfRealConfig& config, Policy& policy);

}  // namespace atacom
