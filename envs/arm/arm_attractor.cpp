#include "envs/arm/arm_attractor.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "atacom/parallel.hpp"
#include "envs/arm/tiago_kinematics.hpp"

namespace atacom {

ArmAttractorPolicy::ArmAttractorPolicy(const ArmEnvConfig& c, const ArmAttractorParams& p)
    : model_(load_tiago_arm_model(c.torso_lift)), p_(p), obs_dim_(c.task == ArmTask::Hri ? kHriObsDim : kArmObsDim) {
  for (int j = 0; j < kArmJoints; ++j) vmax_[size_t(j)] = c.velocity_scale * model_.velocity[size_t(j)];
}

void ArmAttractorPolicy::act_one(const float* o, double* a) const {
  ArmQ q;
  for (int j = 0; j < kArmJoints; ++j) q(j) = o[j];
  const Eigen::Vector3d goal(o[7], o[8], o[9]);
  const ArmFkResult fk = arm_fk_reference(model_, q);
  const Eigen::Matrix3d JJt = fk.J_grasp_pos * fk.J_grasp_pos.transpose() + p_.damping * Eigen::Matrix3d::Identity();
  const ArmQ qdot = fk.J_grasp_pos.transpose() * JJt.ldlt().solve(p_.gain * (goal - fk.grasp.p));
  for (int j = 0; j < kArmJoints; ++j) {
    const double v = vmax_[size_t(j)];
    const double lo = std::max(-v, p_.limit_gain * (model_.lower[size_t(j)] - q(j)));
    const double hi = std::min(v, p_.limit_gain * (model_.upper[size_t(j)] - q(j)));
    // Outside a limit the band is empty: drive back at most at full speed.
    const double x = lo <= hi ? std::clamp(qdot(j), lo, hi) : (lo > 0 ? std::min(lo, v) : std::max(hi, -v));
    a[j] = std::isfinite(x) ? std::clamp(x / v, -1.0, 1.0) : 0.0;
  }
}

void ArmAttractorPolicy::act(const float* obs, int N, bool, Rng*, double* actions) {
  parallel_blocks(N, kEnvBlock, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) act_one(obs + i * obs_dim_, actions + i * kArmJoints);
  });
}

namespace {
std::unique_ptr<Policy> make_for(ArmTask task, const nlohmann::json& resolved_config) {
  ArmEnvConfig c = default_arm_env_config(task);
  from_json(resolved_config, c);
  return std::make_unique<ArmAttractorPolicy>(c);
}
}  // namespace

std::unique_ptr<Policy> make_table_attractor(const nlohmann::json& config) { return make_for(ArmTask::Table, config); }
std::unique_ptr<Policy> make_shelf_attractor(const nlohmann::json& config) { return make_for(ArmTask::Shelf, config); }
std::unique_ptr<Policy> make_hri_attractor(const nlohmann::json& config) { return make_for(ArmTask::Hri, config); }

}  // namespace atacom
