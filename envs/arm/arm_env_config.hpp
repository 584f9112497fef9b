// Config of the manipulation envs (TableEnv, ShelfEnvSim, HRI-Sim): row
// groups' margins and slack shapes, reward, the HRI task, sampling; the one
// default factory per task, validation and JSON (envs/arm/arm_env_config.cpp,
// every key in docs/envs_arm.md).
#pragma once
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "envs/arm/arm_scene.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/tiago_model.hpp"

namespace atacom {

struct ArmRowGroup {
  std::vector<double> margin;  // per row: joint rad; scene/body m; ground: clearance height z, m
  std::vector<double> beta;    // per row: SoftCorner slack shape
  double slack_tol = 1e-6;     // projector slack floor for the group's rows
  std::vector<double> tolerance;  // per row: a row violates when c > tolerance (EnvSpec::constraint_tolerance)
};

struct ArmRewardConfig {
  double rho_d = 1.0;                      // per metre of grasp-to-goal distance
  double rho_ang = 0.1;                    // per radian between approach axis and desired axis
  double rho_a = 0.01;                     // per unit of |a| (normalised applied action)
  double indicator = 0.1;                  // bonus while the grasping frame is in the indicator region
  double terminal = -1000.0;               // reward of a step that ends in collision or joint-limit violation
  Eigen::Vector3d desired_approach{0, 0, -1};  // unit vector, base_footprint
};

// HRI-Sim only (docs/envs_arm.md, section HRI). The cup's axis u is the
// grasping frame's `cup_axis` (a unit vector in that frame); its tilt is the
// angle between u and +z. The paper's task ("hri") keeps the cup upright
// through the reward alone and counts spills as an outcome; "hri-upright"
// (ours) adds a constraint row on the tilt.
struct ArmHriConfig {
  bool upright_row = false;      // true: the cup-upright row (k = 44; hri-upright), false: no row (k = 43; the paper's)
  double theta_max = 0.4363;     // upright row: tilt <= theta_max - upright.margin; 25 deg, rad; unused without the row
  // Spills (counted, never a constraint): a cup 8 cm across filled to 2 cm
  // below its rim overflows, held still, at atan(2 / 4) = 26.6 deg; 1 cm below
  // at atan(1 / 4) = 14 deg (docs/envs_arm.md). Info `spill` at spill_angle,
  // `spill_<deg>` at spill_angle_strict.
  double spill_angle = 0.4363;          // 25 deg, rad
  double spill_angle_strict = 0.2618;   // 15 deg, rad (< spill_angle)
  // true: a spill (its first step, the `spill` column) is a cost event too, so
  // the CMDP learners (`*-lag`) can hold spills to a budget; the reward and
  // every other bit stay the paper's.
  bool spill_cost = false;
  // Starts (and goal configurations) hold the cup within start_tilt of
  // vertical, drawn from a library of such configurations; pi: starts uniform
  // in the joint box as TableEnv's (every orientation; the env before issue 30).
  double start_tilt = 0.1745;    // 10 deg, rad
  Eigen::Vector3d cup_axis{0, -1, 0};  // the grasping frame's -y: vertical in the reference's HRI start pose
  ArmRowGroup human;             // 9 rows: margin beyond the PoI's cover radius, m
  ArmRowGroup upright;           // 1 row: margin in rad below theta_max (hri-upright: 5 deg); read and written with or without the row
  double human_blend = 0.02;     // smooth-min k over the 16 capsules, m (error bound 15 k / 4)
  double rho_tilt = 0.5;         // reward per radian of tilt
  double frames_per_step = 1.0;  // motion frames per env step: 1 = real time (30 Hz library, 30 Hz env); the reference's 0.5 = half speed
  bool compensate_motion = true;   // false: J_x = 0 (ablation: the projector ignores the human's motion)
  HumanSplit split = HumanSplit::Train;
  std::vector<AlignedBox> targets;  // goal regions, one drawn uniformly per episode (reference 4.4)

  // Info column of the strict spill count: "spill_<degrees, rounded>".
  std::string strict_spill_name() const;
};

struct ArmEnvConfig {
  ArmTask task = ArmTask::Table;
  double torso_lift = 0.1;          // fixed torso, m (the authors' kinematic model uses 0.1)
  double dt = 1.0 / 30.0;           // control period, s
  int horizon = 500;                // steps before truncation
  double velocity_scale = 0.5;      // vmax = velocity_scale x URDF velocity
  ArmSceneConfig scene;
  ArmRewardConfig reward;
  ArmRowGroup joint, obstacle, body, ground;  // 14, 9, 9, 2 rows
  ArmHriConfig hri;                           // read and written for task hri only
  std::array<int, 2> ground_poi{3, 8};        // elbow, fingertips (grasping frame)
  double init_margin = 0.02;        // initial states satisfy c <= -init_margin on every row
  int sample_batches = 64;          // x 8 candidates for the initial state and the goal
  double goal_min_distance = 0.15;  // goal at least this far from the initial grasping frame, m
  int goal_library_size = 512;      // safe goal configurations sampled once per env object
  uint64_t goal_library_seed = 1;   // their RNG seed (a property of the task, not of the run)
  double goal_jitter = 0.1;         // per-reset perturbation of a library configuration, rad
  std::array<double, kArmJoints> home{};  // fallback initial configuration (must satisfy the constraints)
  // Distance fields by object (key "table" or "shelf", the env's own; on hri "human" and "table", the
  // shared table; "tiago", the robot body): "analytic", "learned" (the shipped field,
  // envs/arm/arm_learned_sdf.hpp) or "learned:<dir>". Absent = analytic. Defaults:
  // analytic on table and shelf, learned on hri (the paper's ReDSDF constraints).
  std::map<std::string, std::string> sdf;
  // Quality target (time_to_target, docs/training.md): final distance 0.05 m
  // on table and shelf; 0.15 m with no spill on hri.
  EnvTarget target{0.05, {}};

  // Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

// The one default factory per task (documented in docs/envs_arm.md). HRI:
// the paper's task; hri-upright is this plus hri.upright_row = true and an
// upright margin of 5 deg (envs/arm/arm_registry.cpp).
ArmEnvConfig default_arm_env_config(ArmTask task);
void to_json(nlohmann::json& j, const ArmEnvConfig& c);
void from_json(const nlohmann::json& j, ArmEnvConfig& c);  // unknown or missing keys rejected

}  // namespace atacom
