// The static model of a manipulation env (TableEnv, ShelfEnvSim, HRI-Sim):
// robot, scene, composed constraint rows with their offsets, the task, the
// lane kernels' constant tables, learned fields, the human and its replay,
// and the goal library. Built once from a config and shared (read-only) by
// every env of a batch, every thread and every ArmEnv made from it; the
// per-env state is ArmBatch (envs/arm/arm_batch.hpp), the kernels over an
// env range envs/arm/arm_kernels.hpp.
#pragma once
#include <array>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "atacom/env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "envs/arm/arm_env_config.hpp"
#include "envs/arm/arm_rows.hpp"
#include "envs/arm/arm_scene.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_rows.hpp"
#include "envs/arm/tiago_model.hpp"
#include "envs/arm/arm_env_kernel.hpp"

namespace atacom {

constexpr int kArmObsDim = 16;                            // table / shelf observation
constexpr int kHriObsExtra = 3 + 2 * kHumanCapsules * 3;  // cup axis, human capsule midpoints and their velocities
constexpr int kHriObsDim = kArmObsDim + kHriObsExtra;     // 115

constexpr int kArmBlockEnvs = int(kEnvBlock);  // envs per parallel task (include/atacom/parallel.hpp)
static_assert(kArmBlockEnvs % lanes::kLanes == 0, "lane groups must not straddle parallel blocks");

// Info columns, in order (HRI appends four).
enum ArmInfoCol : int {
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
  kInfoSpillStrict,                  // "spill_<deg>": as kInfoSpill at spill_angle_strict
  kInfoCountHri
};

struct ArmModel {
  // Validates the config (std::invalid_argument naming the first bad value),
  // loads robot, scene, fields and human, composes the rows and samples the
  // goal library. Throws if config.home is not a safe start.
  explicit ArmModel(const ArmEnvConfig& config);
  ArmModel(const ArmModel&) = delete;
  ArmModel& operator=(const ArmModel&) = delete;

  ArmEnvConfig config;  // validated; desired_approach and cup_axis normalised
  TiagoArmModel robot;
  ArmScene scene;
  ArmRowLayout rows;    // the composed row groups: k = rows.k, moving groups = rows.moving_groups()
  int k = kArmRows;     // constraint rows
  int dyn = kArmDynamicRows;  // rows with a q-dependent Jacobian (all from kRowScene on)
  int obs_dim = kArmObsDim, info_count = kInfoCount;
  std::vector<double> vmax;                      // (7) joint speed at |a| = 1
  std::array<double, kArmRows> row_offset{};     // thresholds delta (scene/body), heights (ground), joint bounds with margins
  std::array<double, kArmPoi + 1> row_offset_hri{};  // HRI: human deltas, cos(theta_max - margin)
  lanes::ArmKernelConst kern;                    // constant tables of the lane kernels
  std::shared_ptr<LearnedObstacle> learned;      // the obstacle's learned field, or null (analytic)
  std::shared_ptr<LearnedHuman> learned_human;   // HRI: the human's learned field, or null (analytic)
  std::shared_ptr<LearnedObstacle> learned_body; // the robot body's learned field, or null (analytic)
  // HRI (unused otherwise)
  const HumanModel* human = nullptr;             // process-wide, loaded once
  const HumanMotionLibrary* motion = nullptr;    // process-wide, loaded once
  HumanRowsConst human_rows{};                   // thresholds of the human rows
  HumanReplayConfig replay{};
  std::vector<double> robot_radii;               // (items) contact check: link capsules and PoI spheres
  // Goal library: safe configurations with the grasp in the goal region,
  // sampled once from config.goal_library_seed (a property of the task).
  std::vector<double> goal_lib_q;                // (L x 7)
  std::vector<Eigen::Vector3d> goal_lib_p;       // (L) their grasping-frame positions
  // HRI with upright starts (hri.start_tilt < pi): safe configurations that
  // hold the cup within start_tilt of vertical, sampled once like the goal
  // library; each reset jitters one and checks it against the episode's human.
  std::vector<double> start_lib_q;               // (S x 7)
  double cos_start_tilt = -1.0;                  // cos(hri.start_tilt)
  EnvSpec spec;

  bool hri() const { return config.task == ArmTask::Hri; }
  bool upright_starts() const { return hri() && !start_lib_q.empty(); }
  bool in_goal_region(const Eigen::Vector3d& g) const;
  // Every row but the moving groups' (those depend on where the obstacle is)
  // within init_margin, for lane l of a kernel evaluation.
  bool static_rows_ok(const lanes::ArmKernelOut& o, int l) const;
  // A place to start or to deliver to: static_rows_ok and, with upright
  // starts, the cup (o.cup, written by arm_upright_row_lanes) within start_tilt.
  bool pose_ok(const lanes::ArmKernelOut& o, int l) const;
  bool cup_upright(const lanes::ArmKernelOut& o, int l) const {
    return !(hri() && config.hri.start_tilt < kStartTiltUniform) || o.cup[2][l] >= cos_start_tilt;
  }
  static constexpr double kStartTiltUniform = 3.14159265358979323846;  // hri.start_tilt = pi: uniform starts

 private:
  void build_kernel_tables();
  void build_libraries();  // the two below, or their copies from an earlier model of the same config
  void build_goal_library();
  void build_start_library();
  void build_spec();
};

// The human's model and motion library, loaded once per process (every HRI
// model points at them).
const HumanModel& arm_shared_human_model();
const HumanMotionLibrary& arm_shared_human_motion();

// Builds the model once; share the result between ArmEnvs.
std::shared_ptr<const ArmModel> make_arm_model(const ArmEnvConfig& config);

// The projector's model of the env: SoftCorner slacks per group, K_c = 1/dt,
// diagonal G; p = the number of moving groups (HRI: 1, the human's clock).
ProjectorModel arm_projector_model(const ArmModel& m);

}  // namespace atacom
