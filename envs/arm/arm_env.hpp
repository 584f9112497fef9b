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
// body 9, ground 2); HRI adds 9 rows against the human (a moving group:
// J_x = dc/dt, xdot = 1, p = 1), k = 43; hri-upright also the cup-upright
// row, k = 44. HRI counts spills (cup tilt past an angle) as an outcome.
//
// Ground truth, separate from the constraints, decides termination: any link
// capsule or PoI sphere intersecting the obstacle, the floor, the human (HRI)
// or (where checked) the body, or any joint outside its URDF limits. Reward
// -1000 then.
//
// Layout (the projector's pattern): ArmModel (envs/arm/arm_model.hpp) is the
// static part, shared; ArmBatch (envs/arm/arm_batch.hpp) the per-env state;
// the kernels of envs/arm/arm_kernels.hpp work on an env range. ArmEnv is the
// BatchEnv / ControlAffineEnv adapter: it owns a shared model and a batch
// and runs the kernels over fixed parallel blocks (kArmBlockEnvs).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/control_affine_env.hpp"
#include "envs/arm/arm_batch.hpp"
#include "envs/arm/arm_env_config.hpp"
#include "envs/arm/arm_kernels.hpp"
#include "envs/arm/arm_model.hpp"
#include "envs/arm/tiago_kinematics.hpp"

namespace atacom {

class ArmEnv final : public ControlAffineEnv {
 public:
  ArmEnv(const ArmEnvConfig& config, int num_envs);
  // Shares an already built model (no second goal library, field or scene).
  ArmEnv(std::shared_ptr<const ArmModel> model, int num_envs);

  const EnvSpec& spec() const override { return model_->spec; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override;
  void load_state(std::istream& in) override;

  ProjectorModel projector_model() const override { return arm_projector_model(*model_); }
  void constraint_model(ProjectorBatch& pb, int begin, int end) const override {
    arm_constraint_model_range(*model_, batch_, pb, begin, end);
  }

  // HRI adds "human": motion playback, capsule FK, the human rows and the contact check.
  std::vector<std::string> profile_sections() const override {
    if (hri()) return {"kinematics", "distances", "human", "rest"};
    return {"kinematics", "distances", "rest"};
  }
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const std::shared_ptr<const ArmModel>& arm_model() const { return model_; }
  const ArmBatch& batch() const { return batch_; }

  const ArmEnvConfig& config() const { return model_->config; }
  const TiagoArmModel& model() const { return model_->robot; }
  const ArmScene& scene() const { return model_->scene; }
  const std::vector<double>& vmax() const { return model_->vmax; }
  // Row thresholds delta (scene/body) or heights (ground), joint bounds with margins.
  const std::array<double, kArmRows>& row_offset() const { return model_->row_offset; }
  const ArmRowLayout& rows() const { return model_->rows; }
  bool hri() const { return model_->hri(); }
  // Row thresholds of the human group (HRI).
  const HumanRowsConst& human_rows() const { return model_->human_rows; }
  const HumanModel& human_model() const;           // HRI only
  const HumanMotionLibrary& human_motion() const;  // HRI only

  // Scalar reference of the batched evaluation (envs/arm/arm_kernels.hpp).
  ArmEval evaluate_reference(const double* q, const HumanFkResult* human = nullptr) const {
    return atacom::evaluate_reference(*model_, q, human);
  }

  // Per-env state (N x ...), read access for tests and evaluation tools.
  const std::vector<double>& q() const { return batch_.q; }          // (N x 7) joint positions
  const std::vector<double>& goal() const { return batch_.goal; }    // (N x 3) goal positions
  const std::vector<double>& grasp() const { return batch_.grasp; }  // (N x 3) grasping-frame positions
  // HRI: the humans (pose, pose_rate, capsules) and their motion times (frames).
  const HumanBatch& humans() const { return batch_.human.body; }
  const std::vector<double>& human_time() const { return batch_.human.t; }
  // HRI: env i's human capsules (16 x 2 x 3) at the state the last step
  // reached (before an autoreset replaced them), for renderers.
  const double* human_capsules_reached(int i) const {
    const size_t off = static_cast<size_t>(i) * kHumanCapsules * 6;
    return buffers_.done(i) ? &batch_.human.final_cap[off] : &batch_.human.body.cap[off];
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
  bool sample_goal(int i, const double* away_from, double* goal) {
    return arm_sample_goal(*model_, batch_, i, away_from, goal);
  }

 private:
  std::shared_ptr<const ArmModel> model_;
  ArmBatch batch_;
  ArmProfile prof_;
  bool profiling_ = false;
};

// Registry hooks (envs/registry.cpp).
nlohmann::json table_env_default_config();
nlohmann::json shelf_env_default_config();
nlohmann::json hri_env_default_config();
nlohmann::json hri_upright_env_default_config();  // hri + hri.upright_row, margin 5 deg (ours, docs/envs_arm.md)
std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs);
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs);
std::unique_ptr<BatchEnv> make_hri_env(const nlohmann::json& config, int num_envs);
// A resolved "hri" env config written before issue 30 (it has hri.targets but
// no hri.upright_row) described today's hri-upright with uniform starts and an
// analytic table: the keys that say so, added to it (others: unchanged).
nlohmann::json hri_upgrade_pre_issue30_config(const nlohmann::json& overrides);

}  // namespace atacom
