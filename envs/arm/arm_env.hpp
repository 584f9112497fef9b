// Manipulation envs of the paper: TIAGo++ right arm reaching goals above a
// table (TableEnv, "table"), inside a shelf (ShelfEnvSim, "shelf"), or
// carrying a cup upright to a target above a shared table while a replayed
// human moves next to it (HRI-Sim, "hri").
//
// Control: qdot = diag(vmax) a, a in [-1, 1]^7, vmax = velocity_scale x URDF
// velocity limits, integrated exactly over dt (the velocity is constant over a
// step). Torso fixed at config.torso_lift.
//
// Constraints: row groups composed per task (envs/arm/arm_rows.hpp lists
// them; docs/envs_arm.md every row). Table/shelf: k = 34 (joint 14, scene 9,
// body 9, ground 2); HRI adds 9 rows against the human (moving: J_x = dc/dt,
// xdot = 1, p = 1) and the cup-upright row, k = 44.
//
// Ground truth, separate from the constraints, decides termination: any link
// capsule or PoI sphere intersecting the obstacle, the floor, the human (HRI)
// or (where checked) the body, or any joint outside its URDF limits. Reward
// -1000 then.
//
// Per-env state lives in structure-of-arrays vectors; step() runs SIMD lane
// blocks of 8 envs (kernels/arm_env_kernel.hpp) over fixed parallel blocks.
#pragma once
#include <array>
#include <cmath>
#include <atomic>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "envs/arm/arm_rows.hpp"
#include "envs/arm/arm_scene.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_rows.hpp"
#include "atacom/rng.hpp"
#include "atacom/safe_env.hpp"
#include "atacom/safety_layer.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "envs/arm/tiago_model.hpp"

namespace atacom {

namespace lanes {
struct ArmFkLanes;
struct ArmKernelOut;
}  // namespace lanes

constexpr int kArmObsDim = 16;     // table / shelf observation
constexpr int kHriObsExtra = 3 + 2 * kHumanCapsules * 3;  // cup axis, human capsule midpoints and their velocities
constexpr int kHriObsDim = kArmObsDim + kHriObsExtra;       // 115

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
// angle between u and +z.
struct ArmHriConfig {
  double theta_max = 0.4363;     // upright row: tilt <= theta_max - upright.margin (25 deg), rad
  double spill_angle = 0.6981;   // a spill is counted when the tilt exceeds this (40 deg; > theta_max), rad
  Eigen::Vector3d cup_axis{0, -1, 0};  // the grasping frame's -y: vertical in the reference's HRI start pose
  ArmRowGroup human;             // 9 rows: margin beyond the PoI's cover radius, m
  ArmRowGroup upright;           // 1 row: margin in rad below theta_max
  double human_blend = 0.02;     // smooth-min k over the 16 capsules, m (error bound 15 k / 4)
  double rho_tilt = 0.5;         // reward per radian of tilt
  double frames_per_step = 0.5;  // motion frames per env step (reference: one frame every 2 steps)
  bool compensate_motion = true;   // false: J_x = 0 (ablation: the projector ignores the human's motion)
  HumanSplit split = HumanSplit::Train;
  std::vector<AlignedBox> targets;  // goal regions, one drawn uniformly per episode (reference 4.4)
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
  // Distance fields by object (key "table" or "shelf", the env's own; "human" on hri; "tiago", the robot body):
  // "analytic" (default), "learned" (the shipped data/sdf/<object>) or
  // "learned:<dir>" (envs/arm/arm_learned_sdf.hpp). Absent = analytic.
  std::map<std::string, std::string> sdf;

  // Throws std::invalid_argument naming the first bad value.
  void validate() const;
};

// The one default factory per task (documented in docs/envs_arm.md).
ArmEnvConfig default_arm_env_config(ArmTask task);
void to_json(nlohmann::json& j, const ArmEnvConfig& c);
void from_json(const nlohmann::json& j, ArmEnvConfig& c);  // unknown or missing keys rejected

// Everything the env derives from q, for one configuration (scalar, plain
// Eigen: the reference the batched kernel is tested against).
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

class ArmEnv final : public ControlAffineEnv {
 public:
  ArmEnv(const ArmEnvConfig& config, int num_envs);

  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override;
  void load_state(std::istream& in) override;

  ProjectorModel projector_model() const override;
  void constraint_model(ProjectorBatch& pb, int begin, int end) const override;

  // HRI adds "human": motion playback, capsule FK, the human rows and the contact check.
  std::vector<std::string> profile_sections() const override {
    if (hri()) return {"kinematics", "distances", "human", "rest"};
    return {"kinematics", "distances", "rest"};
  }
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const ArmEnvConfig& config() const { return config_; }
  const TiagoArmModel& model() const { return model_; }
  const ArmScene& scene() const { return scene_; }
  const std::vector<double>& vmax() const { return vmax_; }
  // Row thresholds delta (scene/body) or heights (ground), joint bounds with margins.
  const std::array<double, kArmRows>& row_offset() const { return row_offset_; }

  const ArmRowLayout& rows() const { return rows_; }
  bool hri() const { return config_.task == ArmTask::Hri; }
  // Row thresholds of the human group (HRI).
  const HumanRowsConst& human_rows() const { return human_rows_; }
  const HumanModel& human_model() const;           // HRI only
  const HumanMotionLibrary& human_motion() const;  // HRI only

  // Scalar reference of the batched evaluation (tests, tools). HRI: `human`
  // holds the capsules (with velocities) of human_fk_reference; without one
  // the human rows read -inf (no human) and dcdt 0.
  ArmEval evaluate_reference(const double* q, const HumanFkResult* human = nullptr) const;

  // Per-env state (N x ...), read access for tests and evaluation tools.
  const std::vector<double>& q() const { return q_; }          // (N x 7) joint positions
  const std::vector<double>& goal() const { return goal_; }    // (N x 3) goal positions
  const std::vector<double>& grasp() const { return grasp_; }  // (N x 3) grasping-frame positions
  // HRI: the humans (pose, pose_rate, capsules) and their motion times (frames).
  const HumanBatch& humans() const { return humans_; }
  const std::vector<double>& human_time() const { return human_t_; }
  // HRI: env i's human capsules (16 x 2 x 3) at the state the last step
  // reached (before an autoreset replaced them), for renderers.
  const double* human_capsules_reached(int i) const {
    const size_t off = static_cast<size_t>(i) * kHumanCapsules * 6;
    return buffers_.done(i) ? &final_cap_[off] : &humans_.cap[off];
  }
  // HRI: place env i's human at motion time t (frames) and recompute its rows.
  void set_human_time(int i, double t);
  // Place env i in a given state (evaluation protocols, tests): sets q and the
  // goal, restarts its episode counters, recomputes its cached model and obs.
  void set_state(int i, const double* q, const double* goal);
  void set_goal(int i, const double* goal);  // keeps q and the episode running
  // Draw a goal for env i from its own stream (safe configuration with the
  // grasping frame in the goal region, at least goal_min_distance from
  // away_from); false if it fell back to a library goal without jitter.
  bool sample_goal(int i, const double* away_from, double* goal);

 private:
  struct Kernel;
  void build_spec();
  void eval_group(int e0, int count, const double* actions);
  void reset_env(int e);
  void write_obs(int e, float* obs) const;
  void refresh(int e);  // recompute cache + obs of env e from q_ (scalar-lane path)
  void build_goal_library();
  bool in_goal_region(const Eigen::Vector3d& g) const;
  void human_at(int e0, int count);  // poses and capsules of envs' humans at human_t_
  bool static_rows_ok(const lanes::ArmKernelOut& o, int l) const;
  double arm_scene_distance_reference(const Eigen::Vector3d& p, Eigen::Vector3d* grad) const;
  // Copy lane l of a kernel evaluation into env e's cached model (Jacobians
  // into the lane-major cache when with_jacobian).
  void store_lane(const lanes::ArmFkLanes& fk, const lanes::ArmKernelOut& o, int l, int e, bool with_jacobian);

  ArmEnvConfig config_;
  TiagoArmModel model_;
  ArmScene scene_;
  EnvSpec spec_;
  std::vector<double> vmax_;                 // (7) joint speed at |a| = 1
  std::vector<double> goal_lib_q_;           // (L x 7) safe configurations with the grasp in the goal region
  std::vector<Eigen::Vector3d> goal_lib_p_;  // (L) their grasping-frame positions
  std::array<double, kArmRows> row_offset_{};
  std::array<double, kArmPoi + 1> row_offset_hri_{};  // HRI: human deltas, cos(theta_max - margin)
  std::shared_ptr<const Kernel> kernel_;     // constant lane-kernel tables
  ArmRowLayout rows_;
  int k_ = kArmRows, dyn_ = kArmDynamicRows, obs_dim_ = kArmObsDim, info_count_ = 0;
  HumanRowsConst human_rows_{};
  HumanReplayConfig replay_{};
  std::vector<double> robot_radii_;          // (items) HRI contact check: link capsules and PoI spheres

  // per-env state, written by step()/reset()
  std::vector<double> q_;          // (N x 7)  joint positions
  std::vector<double> goal_;       // (N x 3)  goal position
  std::vector<int32_t> t_;         // (N)      steps into the episode
  std::vector<double> ret_;        // (N)      running undiscounted return
  std::vector<Rng> rng_;           // (N)      per-env stream keyed (seed, env id)
  std::vector<uint8_t> fallback_;  // (N)      1 if the last reset used a fallback (home or region centre)
  // cached model of the current state, written by eval_group()/reset_env()
  std::vector<double> c_;          // (N x 34)      constraint values
  std::vector<double> J_;          // (ceil(N/8) x (k-14) x 7 x 8) Jacobians of rows 14..k-1, lane-major per group of 8 envs
  std::vector<double> grasp_;      // (N x 3)       grasping-frame position
  std::vector<double> approach_;   // (N x 3)       approach axis (grasping frame x)
  // HRI only (empty otherwise)
  HumanBatch humans_;              // (N) poses and capsules at human_t_
  std::vector<double> human_t_;    // (N)           motion time, frames
  std::vector<double> dcdt_;       // (N x 9)       J_x of the human rows
  std::vector<double> cup_;        // (N x 3)       cup axis
  std::vector<double> min_hd_;     // (N)           smallest human distance so far in the episode
  std::vector<uint8_t> spilled_;   // (N)           1 once the episode had a spill
  std::vector<double> items_;      // (N x items x 6) robot parts in the base frame (contact scratch)
  std::vector<uint8_t> contact_;   // (N)           human contact of the last step
  std::vector<double> hd_;         // (N)           robot-to-human distance of the last step
  std::vector<double> final_cap_;  // (N x 16 x 6)  capsules of an episode's last step (written on autoreset)
  uint64_t seed_ = 0;

  std::atomic<int64_t> prof_ns_[4] = {0, 0, 0, 0};
  bool profiling_ = false;
};

// Registry hooks (envs/registry.cpp).
nlohmann::json arm_sac_defaults(SafetyLayer safety);  // per-env SAC settings (reference 5.4)
nlohmann::json table_env_default_config();
nlohmann::json shelf_env_default_config();
nlohmann::json hri_env_default_config();
nlohmann::json hri_sac_defaults(SafetyLayer safety);  // arm_sac_defaults + 512-512-256 networks
std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs);
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs);
std::unique_ptr<BatchEnv> make_hri_env(const nlohmann::json& config, int num_envs);

}  // namespace atacom
