// ArmEnv, the adapter: the BatchEnv contract over the kernels of
// envs/arm/arm_kernels.hpp on fixed parallel blocks, the per-env setters of
// evaluation protocols, profiling. Snapshots: envs/arm/arm_snapshot.cpp.
#include "envs/arm/arm_env.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/parallel.hpp"

namespace atacom {

ArmEnv::ArmEnv(const ArmEnvConfig& config, int num_envs) : ArmEnv(make_arm_model(config), num_envs) {}

ArmEnv::ArmEnv(std::shared_ptr<const ArmModel> model, int num_envs) : model_(std::move(model)) {
  if (!model_) throw std::invalid_argument("arm env: no model");
  if (num_envs < 1) throw std::invalid_argument("number of envs must be >= 1");
  batch_.resize(*model_, num_envs);
  buffers_.resize(model_->spec, num_envs);
  seed(0);
}

const HumanModel& ArmEnv::human_model() const { return arm_shared_human_model(); }
const HumanMotionLibrary& ArmEnv::human_motion() const { return arm_shared_human_motion(); }

void ArmEnv::seed(uint64_t seed) {
  batch_.seed = seed;
  for (size_t i = 0; i < batch_.rng.size(); ++i) batch_.rng[i].reseed(seed, i);
  reset(nullptr);
}

void ArmEnv::reset(const uint8_t* mask) {
  parallel_blocks(num_envs(), kArmBlockEnvs, [&](int64_t lo, int64_t hi) {
    arm_reset_range(*model_, batch_, buffers_, mask, static_cast<int>(lo), static_cast<int>(hi));
  });
}

void ArmEnv::step(const double* actions) {
  ArmProfile* prof = profiling_ ? &prof_ : nullptr;
  parallel_blocks(num_envs(), kArmBlockEnvs, [&](int64_t lo, int64_t hi) {
    arm_step_range(*model_, batch_, buffers_, actions, static_cast<int>(lo), static_cast<int>(hi), prof);
  });
}

void ArmEnv::set_profiling(bool on) {
  profiling_ = on;
  for (auto& p : prof_.ns) p.store(0);
}

std::vector<double> ArmEnv::profile_seconds() const {
  std::vector<double> out;
  for (size_t i = 0; i < profile_sections().size(); ++i) out.push_back(prof_.ns[i].load() * 1e-9);
  return out;
}

void ArmEnv::set_human_time(int i, double t) {
  batch_.human.t[static_cast<size_t>(i)] = t;
  arm_human_at(*model_, batch_, i, i + 1);
  arm_refresh(*model_, batch_, i, buffers_.obs.data());
}

void ArmEnv::set_state(int i, const double* q, const double* goal) {
  const size_t se = static_cast<size_t>(i);
  std::copy(q, q + kArmJoints, &batch_.q[se * kArmJoints]);
  std::copy(goal, goal + 3, &batch_.goal[se * 3]);
  batch_.t[se] = 0;
  batch_.ret[se] = 0.0;
  if (model_->hri()) {  // the episode's spill flags and closest approach start over too
    batch_.spilled[se] = 0;
    batch_.min_hd[se] = INFINITY;
  }
  arm_refresh(*model_, batch_, i, buffers_.obs.data());
}

void ArmEnv::set_goal(int i, const double* goal) {
  std::copy(goal, goal + 3, &batch_.goal[static_cast<size_t>(i) * 3]);
  arm_write_obs(*model_, batch_, i, &buffers_.obs[static_cast<size_t>(i) * model_->obs_dim]);
}

}  // namespace atacom
