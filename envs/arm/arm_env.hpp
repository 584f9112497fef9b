// Manipulation envs of the paper: TIAGo++ right arm reaching goals above a
// table (TableEnv, "table") or inside a shelf (ShelfEnvSim, "shelf").
//
// Control: qdot = diag(vmax) a, a in [-1, 1]^7, vmax = velocity_scale x URDF
// velocity limits, integrated exactly over dt (the velocity is constant over a
// step). Torso fixed at config.torso_lift.
//
// Constraints, k = 34 rows c(q) <= 0 (docs/envs_arm.md lists every row):
//   rows  0..6   joint lower limits   (lower_j + margin_j) - q_j
//   rows  7..13  joint upper limits   q_j - (upper_j - margin_j)
//   rows 14..22  PoI to obstacle      delta_i - d_obstacle(p_i(q)),  delta_i = scene_cover_i + margin_i
//   rows 23..31  PoI to robot body    delta_i - d_body(p_i(q)),      delta_i = body_cover_i + margin_i
//   rows 32..33  ground clearance     h_i - z(p_i(q)) for the elbow and the grasping frame
// Jacobians: -grad d . J_poi (rows 14..33), -/+ e_j (joint rows).
//
// Ground truth, separate from the constraints, decides termination: any link
// capsule or PoI sphere intersecting the obstacle, the floor or (where
// checked) the body, or any joint outside its URDF limits. Reward -1000 then.
//
// Per-env state lives in structure-of-arrays vectors; step() runs SIMD lane
// blocks of 8 envs (kernels/arm_env_kernel.hpp) over fixed parallel blocks.
#pragma once
#include <array>
#include <atomic>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "envs/arm/arm_scene.hpp"
#include "atacom/rng.hpp"
#include "atacom/safe_env.hpp"
#include "atacom/safety_layer.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "envs/arm/tiago_model.hpp"

namespace atacom {

constexpr int kArmRows = 34;
constexpr int kRowJointLower = 0;
constexpr int kRowJointUpper = 7;
constexpr int kRowScene = 14;
constexpr int kRowBody = 23;
constexpr int kRowGround = 32;
constexpr int kArmDynamicRows = kArmRows - kRowScene;  // rows whose Jacobian depends on q
constexpr int kArmObsDim = 16;

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

struct ArmEnvConfig {
  ArmTask task = ArmTask::Table;
  double torso_lift = 0.1;          // fixed torso, m (the authors' kinematic model uses 0.1)
  double dt = 1.0 / 30.0;           // control period, s
  int horizon = 500;                // steps before truncation
  double velocity_scale = 0.5;      // vmax = velocity_scale x URDF velocity
  ArmSceneConfig scene;
  ArmRewardConfig reward;
  ArmRowGroup joint, obstacle, body, ground;  // 14, 9, 9, 2 rows
  std::array<int, 2> ground_poi{3, 8};        // elbow, fingertips (grasping frame)
  double init_margin = 0.02;        // initial states satisfy c <= -init_margin on every row
  int sample_batches = 64;          // x 8 candidates for the initial state and the goal
  double goal_min_distance = 0.15;  // goal at least this far from the initial grasping frame, m
  int goal_library_size = 512;      // safe goal configurations sampled once per env object
  uint64_t goal_library_seed = 1;   // their RNG seed (a property of the task, not of the run)
  double goal_jitter = 0.1;         // per-reset perturbation of a library configuration, rad
  std::array<double, kArmJoints> home{};  // fallback initial configuration (must satisfy the constraints)
  // Distance fields by object (key "table" or "shelf", the env's own):
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
  Eigen::Matrix<double, kArmRows, 1> c;
  Eigen::Matrix<double, kArmRows, kArmJoints> J;
  Eigen::Vector3d grasp_p, approach;
  bool collision = false;        // ground-truth contact
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

  std::vector<std::string> profile_sections() const override { return {"kinematics", "distances", "rest"}; }
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const ArmEnvConfig& config() const { return config_; }
  const TiagoArmModel& model() const { return model_; }
  const ArmScene& scene() const { return scene_; }
  const std::vector<double>& vmax() const { return vmax_; }
  // Row thresholds delta (scene/body) or heights (ground), joint bounds with margins.
  const std::array<double, kArmRows>& row_offset() const { return row_offset_; }

  // Scalar reference of the batched evaluation (tests, tools).
  ArmEval evaluate_reference(const double* q) const;

  // Per-env state (N x ...), read access for tests and evaluation tools.
  const std::vector<double>& q() const { return q_; }          // (N x 7) joint positions
  const std::vector<double>& goal() const { return goal_; }    // (N x 3) goal positions
  const std::vector<double>& grasp() const { return grasp_; }  // (N x 3) grasping-frame positions
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

  ArmEnvConfig config_;
  TiagoArmModel model_;
  ArmScene scene_;
  EnvSpec spec_;
  std::vector<double> vmax_;                 // (7) joint speed at |a| = 1
  std::vector<double> goal_lib_q_;           // (L x 7) safe configurations with the grasp in the goal region
  std::array<double, kArmRows> row_offset_{};
  std::shared_ptr<const Kernel> kernel_;     // constant lane-kernel tables

  // per-env state, written by step()/reset()
  std::vector<double> q_;          // (N x 7)  joint positions
  std::vector<double> goal_;       // (N x 3)  goal position
  std::vector<int32_t> t_;         // (N)      steps into the episode
  std::vector<double> ret_;        // (N)      running undiscounted return
  std::vector<Rng> rng_;           // (N)      per-env stream keyed (seed, env id)
  std::vector<uint8_t> fallback_;  // (N)      1 if the last reset used a fallback (home or region centre)
  // cached model of the current state, written by eval_group()/reset_env()
  std::vector<double> c_;          // (N x 34)      constraint values
  std::vector<double> J_;          // (ceil(N/8) x 20 x 7 x 8) Jacobians of rows 14..33, lane-major per group of 8 envs
  std::vector<double> grasp_;      // (N x 3)       grasping-frame position
  std::vector<double> approach_;   // (N x 3)       approach axis (grasping frame x)
  uint64_t seed_ = 0;

  std::atomic<int64_t> prof_ns_[3] = {0, 0, 0};
  bool profiling_ = false;
};

// Registry hooks (envs/registry.cpp).
nlohmann::json arm_sac_defaults(SafetyLayer safety);  // per-env SAC settings (reference 5.4)
nlohmann::json table_env_default_config();
nlohmann::json shelf_env_default_config();
std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs);
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs);

}  // namespace atacom
