// The paper's Linear Attractor (LA) for the arm envs (table, shelf), behind
// the Policy contract (reference digest 6.2):
//   qdot = J_pos^+ K (p_goal - p_grasp),   K = gain I (the authors' K = I),
// J_pos^+ the right pseudo-inverse J^T (J J^T + damping I)^-1, then clipped
// per joint to the velocity limit and to a joint-limit band,
//   max(-v_j, k_lim (q_low_j - q_j)) <= qdot_j <= min(v_j, k_lim (q_up_j - q_j)),
// with v_j the env's velocity limit (velocity_scale x URDF), q_low/q_up the
// URDF limits and k_lim = 5. The public reference writes the lower bound as
// -max(v, 5 (q_low - q)), which is always -v (its 5 (q_low - q) is negative
// inside the limits), so its band never slows a joint approaching its lower
// limit; this is the intended bound. The action is qdot / v_j, in [-1, 1].
// It reads q (obs 0..6) and the goal (obs 7..9) from the observation, so it
// runs unchanged on the plain env (LA) and as ATACOM's alpha (LA-ATACOM).
#pragma once
#include <array>
#include <memory>

#include <nlohmann/json_fwd.hpp>

#include "atacom/policy.hpp"
#include "envs/arm/arm_env.hpp"

namespace atacom {

struct ArmAttractorParams {
  double gain = 1.0;        // K = gain I, 1/s
  double limit_gain = 5.0;  // joint-limit band slope, 1/s
  double damping = 1e-6;    // of J J^T, m^2 (guards singular configurations)
};

class ArmAttractorPolicy final : public Policy {
 public:
  ArmAttractorPolicy(const ArmEnvConfig& env_config, const ArmAttractorParams& params = ArmAttractorParams{});
  int obs_dim() const override { return obs_dim_; }
  int act_dim() const override { return kArmJoints; }
  std::string kind() const override { return "attractor"; }
  // Deterministic; `deterministic` and `rngs` are unused.
  void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) override;
  // One env (the scalar the batch runs per row).
  void act_one(const float* obs, double* action) const;

 private:
  TiagoArmModel model_;
  ArmAttractorParams p_;
  std::array<double, kArmJoints> vmax_{};
  int obs_dim_ = kArmObsDim;  // HRI: kHriObsDim (the attractor reads the first 10 entries only)
};

// Registry hooks (EnvEntry::make_attractor) of table and shelf.
std::unique_ptr<Policy> make_table_attractor(const nlohmann::json& resolved_config);
std::unique_ptr<Policy> make_shelf_attractor(const nlohmann::json& resolved_config);
std::unique_ptr<Policy> make_hri_attractor(const nlohmann::json& resolved_config);

}  // namespace atacom
