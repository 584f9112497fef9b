// Kernels of the manipulation envs: free functions (const ArmModel&,
// ArmBatch&, env range) that write only the batch (and the env buffers they
// are given); ArmEnv calls them over fixed parallel blocks
// (kArmBlockEnvs). Inside, lane groups of 8 envs run the SIMD kernels of
// envs/arm/arm_env_kernel.hpp. Beside them the scalar per-env reference
// (evaluate_reference, plain Eigen) that the batched path is tested against.
#pragma once
#include <atomic>
#include <cmath>
#include <cstdint>

#include <Eigen/Core>

#include "atacom/env.hpp"
#include "atacom/projector.hpp"
#include "envs/arm/arm_batch.hpp"
#include "envs/arm/arm_model.hpp"

namespace atacom {

// Time split of step (benchmarks): kinematics, distances, [human,] rest.
struct ArmProfile {
  std::atomic<int64_t> ns[4] = {0, 0, 0, 0};
};

// Reset envs e in [begin, end) with mask[e] != 0 (all when mask is null):
// draws the episode's obstacle state, a safe start and a goal from env e's
// stream, and writes obs, final_obs, constraints, reward, cost, done flags
// and info of the env.
void arm_reset_range(const ArmModel& m, ArmBatch& b, EnvBuffers& out, const uint8_t* mask, int begin, int end);

// One control step of envs [begin, end) (any range; whole lane groups take
// the vector path): integrate, advance the moving obstacles, rows and
// ground truth of the reached state, reward, termination, obs, autoreset.
// actions: (N x 7). prof: null, or the sections' nanoseconds to add to.
void arm_step_range(const ArmModel& m, ArmBatch& b, EnvBuffers& out, const double* actions, int begin, int end,
                    ArmProfile* prof);

// The projector's inputs of envs [begin, end): c, G = diag(vmax), J_q (the
// joint rows' constant part, the rest from the lane-major cache) and, for
// every moving group, its J_x column and xdot.
void arm_constraint_model_range(const ArmModel& m, const ArmBatch& b, ProjectorBatch& pb, int begin, int end);

// Env e alone: recompute its cached model from q and its obstacle's state,
// and its observation into obs (N x obs_dim, row e written).
void arm_refresh(const ArmModel& m, ArmBatch& b, int e, float* obs);
void arm_write_obs(const ArmModel& m, const ArmBatch& b, int e, float* obs_row);
// Moving obstacles of envs [begin, end) at their times b.human.t: poses,
// rates, capsules and capsule velocities.
void arm_human_at(const ArmModel& m, ArmBatch& b, int begin, int end);
// A goal for env e from its own stream (safe configuration with the grasping
// frame in the goal region, at least goal_min_distance from away_from);
// false if it fell back to a library goal without jitter.
bool arm_sample_goal(const ArmModel& m, ArmBatch& b, int e, const double* away_from, double* goal);

// Everything the env derives from q, for one configuration.
struct ArmEval {
  Eigen::VectorXd c;             // (k)
  Eigen::MatrixXd J;             // (k x 7) J_q
  Eigen::VectorXd dcdt;          // (k) J_x for x = human time (0 off the human rows)
  Eigen::Vector3d grasp_p, approach, cup_axis;
  double tilt = 0.0;             // rad
  double human_distance = INFINITY;  // HRI: exact smallest robot-to-human surface distance
  bool collision = false;        // ground-truth contact (static scene, or the human in HRI)
  bool human_collision = false;  // HRI: with the human
  bool joint_violation = false;  // outside the URDF limits
};

// Scalar reference of the batched evaluation (envs/arm/arm_reference.cpp).
// HRI: `human` holds the capsules (with velocities) of human_fk_reference;
// without one the human rows read -inf (no human) and dcdt 0.
ArmEval evaluate_reference(const ArmModel& m, const double* q, const HumanFkResult* human = nullptr);

// Scalar twin of lanes::arm_scene_distance_lanes (the learned-field seam).
double arm_scene_distance_reference(const ArmModel& m, const Eigen::Vector3d& p, Eigen::Vector3d* grad);

}  // namespace atacom
