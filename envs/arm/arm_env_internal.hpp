// Shared by the translation units of ArmEnv (not a public header).
#pragma once
#include "envs/arm/arm_env.hpp"
#include "kernels/arm_env_kernel.hpp"
#include "kernels/lanes.hpp"

namespace atacom::arm_env_detail {

constexpr int kBlockEnvs = 256;  // envs per parallel task: fixed, so results never depend on threads
static_assert(kBlockEnvs % lanes::kLanes == 0, "lane groups must not straddle parallel blocks");

// Info columns, in order (HRI appends four).
enum InfoCol : int {
  kInfoCollision = 0,  // any ground-truth collision (HRI: the human's included)
  kInfoJointViolation,
  kInfoFinalDistance,
  kInfoDistance,
  kInfoAngle,
  kInfoInRegion,
  kInfoNanAction,
  kInfoResetFallback,
  kInfoCount,
  kInfoHumanCollision = kInfoCount,  // HRI
  kInfoSpill,                        // 1 at the first step of an episode whose tilt exceeds spill_angle
  kInfoMinHumanDistance,             // smallest robot-to-human surface distance so far in the episode, m
  kInfoTilt,                         // cup tilt, rad
  kInfoCountHri
};

}  // namespace atacom::arm_env_detail

namespace atacom {
struct ArmEnv::Kernel {
  lanes::ArmKernelConst k;
  std::shared_ptr<LearnedObstacle> learned;  // the obstacle's learned field, or null (analytic)
  std::shared_ptr<LearnedHuman> learned_human;  // HRI: the human's learned field, or null (analytic)
  std::shared_ptr<LearnedObstacle> learned_body;  // the robot body's learned field, or null (analytic)
  explicit Kernel(const TiagoArmModel& m) : k(m) {}
};
}  // namespace atacom
