#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_learned_sdf.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <istream>
#include <ostream>
#include <stdexcept>

#include "atacom/parallel.hpp"
#include "kernels/arm_env_kernel.hpp"

namespace atacom {

namespace {

using nlohmann::json;
using lanes::kLanes;
using lanes::vd;

constexpr int kBlockEnvs = 256;  // envs per parallel task: fixed, so results never depend on threads
static_assert(kBlockEnvs % kLanes == 0, "lane groups must not straddle parallel blocks");

// Info columns, in order.
enum InfoCol : int {
  kInfoCollision = 0,
  kInfoJointViolation,
  kInfoFinalDistance,
  kInfoDistance,
  kInfoAngle,
  kInfoInRegion,
  kInfoNanAction,
  kInfoResetFallback,
  kInfoCount
};


double num(const json& j, const std::string& what) {
  if (!j.is_number()) throw std::invalid_argument(what + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw std::invalid_argument(what + " must be finite");
  return v;
}

std::vector<double> num_array(const json& j, size_t n, const std::string& what) {
  if (!j.is_array() || j.size() != n)
    throw std::invalid_argument(what + " must be an array of " + std::to_string(n) + " numbers");
  std::vector<double> v;
  for (size_t i = 0; i < n; ++i) v.push_back(num(j[i], what));
  return v;
}

json group_json(const ArmRowGroup& g) {
  return {{"margin", g.margin}, {"beta", g.beta}, {"slack_tol", g.slack_tol}, {"tolerance", g.tolerance}};
}

ArmRowGroup read_group(const json& j, size_t rows, const std::string& section) {
  ConfigReader r(j, section);
  ArmRowGroup g;
  g.margin = num_array(r.at("margin"), rows, r.path("margin"));
  g.beta = num_array(r.at("beta"), rows, r.path("beta"));
  g.slack_tol = r.number("slack_tol", range::open(0.0, 1.0));
  g.tolerance = num_array(r.at("tolerance"), rows, r.path("tolerance"));
  r.finish();
  return g;
}

ArmRowGroup make_group(size_t rows, double margin, double beta, double slack_tol, double tolerance) {
  return {std::vector<double>(rows, margin), std::vector<double>(rows, beta), slack_tol,
          std::vector<double>(rows, tolerance)};
}

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

// ---------------------------------------------------------------- config

ArmEnvConfig default_arm_env_config(ArmTask task) {
  ArmEnvConfig c;
  c.task = task;
  c.scene = default_arm_scene_config(task);
  c.sdf = {{arm_task_name(task), "analytic"}};
  c.reward.desired_approach = {1.0, 0.0, 0.0};  // reach forward, gripper horizontal
  // Joint rows: 0.05 rad inside the URDF limits (the authors' base env clips
  // position targets 0.05 rad inside), beta 30 as in their joint-limit rows.
  // Tolerance 0.03 rad: rows overshoot only when conflicting rows leave the
  // projector no feasible correction inside the action box.
  c.joint = make_group(2 * kArmJoints, 0.05, 30.0, 1e-6, 0.03);
  // Distance rows: margin beyond the cover radius; beta 30 / m lets the slack
  // move freely until about 2 cm from the boundary. The distal PoIs move up to
  // ~8 cm per step, and a first-order step around an edge of radius d
  // overshoots by about (v dt)^2 / (2 d), so they get larger margins and
  // tolerances (measured maxima in docs/envs_arm.md).
  c.obstacle = make_group(kArmPoi, 0.02, 30.0, 1e-6, 0.01);
  c.body = make_group(kArmPoi, 0.02, 30.0, 1e-6, 0.01);
  const double distal_margin[3] = {0.03, 0.06, 0.06}, distal_tol[3] = {0.02, 0.05, 0.05};
  for (int i = 0; i < 3; ++i) {  // gripper_palm, gripper_fingers, fingertips
    c.obstacle.margin[6 + i] = c.body.margin[6 + i] = distal_margin[i];
    c.obstacle.tolerance[6 + i] = c.body.tolerance[6 + i] = distal_tol[i];
  }
  // Ground rows hold absolute heights (m) of the elbow and the grasping frame.
  // Within tolerance they keep the elbow PoI above 0.50 m and the grasping
  // frame above 0.28 m; every other PoI is within a fixed distance of one of
  // them (wrist_2 0.345 m from the elbow, palm 0.16 m from the grasping
  // frame, ...), which keeps all link capsules off the floor (docs/envs_arm.md).
  c.ground = make_group(2, 0.30, 30.0, 1e-6, 0.02);
  c.ground.margin[0] = 0.52;
  // Fallback start, used only if sample_batches x 8 random starts all fail:
  // the most interior of 200k random configurations (every row <= -0.11 in
  // both scenes; checked safe at construction).
  c.home = {0.0, 0.408, 1.389, 0.511, -0.735, 0.935, 1.684};
  return c;
}

void ArmEnvConfig::validate() const {
  if (!(dt > 0.0 && dt < 1.0)) throw std::invalid_argument("config: env.dt must be in (0, 1) s");
  if (horizon < 1) throw std::invalid_argument("config: env.horizon must be >= 1");
  if (!(velocity_scale > 0.0 && velocity_scale <= 1.0)) throw std::invalid_argument("config: env.velocity_scale must be in (0, 1]");
  if (!(torso_lift >= 0.0 && torso_lift <= 0.35)) throw std::invalid_argument("config: env.torso_lift must be in [0, 0.35] m");
  auto check_group = [](const ArmRowGroup& g, size_t rows, const std::string& what, bool margin_is_height) {
    if (g.margin.size() != rows || g.beta.size() != rows || g.tolerance.size() != rows)
      throw std::invalid_argument("config: env." + what + ": margin, beta and tolerance need " + std::to_string(rows) + " entries");
    for (size_t i = 0; i < rows; ++i) {
      if (!(g.beta[i] > 0.0) || !std::isfinite(g.beta[i])) throw std::invalid_argument("config: env." + what + ".beta must be > 0");
      if (!(g.tolerance[i] >= 0.0)) throw std::invalid_argument("config: env." + what + ".tolerance must be >= 0");
      if (!margin_is_height && !(g.margin[i] >= g.tolerance[i]))
        throw std::invalid_argument("config: env." + what + ".margin must be >= env." + what +
                                    ".tolerance, so that a row within tolerance still keeps the margin's guarantee");
    }
    if (!(g.slack_tol > 0.0 && g.slack_tol < 1.0)) throw std::invalid_argument("config: env." + what + ".slack_tol must be in (0, 1)");
  };
  check_group(joint, 2 * kArmJoints, "constraints.joint", false);
  check_group(obstacle, kArmPoi, "constraints.obstacle", false);
  check_group(body, kArmPoi, "constraints.body", false);
  check_group(ground, 2, "constraints.ground", true);
  for (int p : ground_poi)
    if (p < 0 || p >= kArmPoi) throw std::invalid_argument("config: env.constraints.ground_poi entries must be PoI indices 0..8");
  if (!(reward.desired_approach.norm() > 0.5 && reward.desired_approach.norm() < 2.0))
    throw std::invalid_argument("config: env.reward.desired_approach must be a unit vector");
  if (!(init_margin >= 0.0)) throw std::invalid_argument("config: env.init_margin must be >= 0");
  if (sample_batches < 1) throw std::invalid_argument("config: env.sample_batches must be >= 1");
  if (!(goal_min_distance >= 0.0)) throw std::invalid_argument("config: env.goal_min_distance must be >= 0");
  if (goal_library_size < 1) throw std::invalid_argument("config: env.goal_library_size must be >= 1");
  if (!(goal_jitter >= 0.0 && goal_jitter < 1.0)) throw std::invalid_argument("config: env.goal_jitter must be in [0, 1) rad");
}

void to_json(json& j, const ArmEnvConfig& c) {
  const Eigen::Vector3d& d = c.reward.desired_approach;
  j = {{"torso_lift", c.torso_lift},
       {"dt", c.dt},
       {"horizon", c.horizon},
       {"velocity_scale", c.velocity_scale},
       {"scene", c.scene},
       {"reward",
        {{"rho_d", c.reward.rho_d},
         {"rho_ang", c.reward.rho_ang},
         {"rho_a", c.reward.rho_a},
         {"indicator", c.reward.indicator},
         {"terminal", c.reward.terminal},
         {"desired_approach", {d.x(), d.y(), d.z()}}}},
       {"constraints",
        {{"joint", group_json(c.joint)},
         {"obstacle", group_json(c.obstacle)},
         {"body", group_json(c.body)},
         {"ground", group_json(c.ground)},
         {"ground_poi", c.ground_poi}}},
       {"init_margin", c.init_margin},
       {"sample_batches", c.sample_batches},
       {"goal_min_distance", c.goal_min_distance},
       {"goal_library_size", c.goal_library_size},
       {"goal_library_seed", c.goal_library_seed},
       {"goal_jitter", c.goal_jitter},
       {"home", c.home}};
  if (!c.sdf.empty()) j["sdf"] = c.sdf;
}

void from_json(const json& j, ArmEnvConfig& c) {
  ConfigReader r(j, "env");
  c.torso_lift = r.number("torso_lift", range::closed(0.0, 0.35));
  c.dt = r.number("dt", range::open(0.0, 1.0));
  c.horizon = r.integer("horizon", range::closed(1, limits::kMaxHorizon));
  c.velocity_scale = r.number("velocity_scale", range::open_closed(0.0, 1.0));
  const ArmTask task = c.task;
  from_json(r.at("scene"), c.scene);
  c.scene.task = task;
  {
    ConfigReader s(r.at("reward"), r.path("reward"));
    c.reward.rho_d = s.number("rho_d");
    c.reward.rho_ang = s.number("rho_ang");
    c.reward.rho_a = s.number("rho_a");
    c.reward.indicator = s.number("indicator");
    c.reward.terminal = s.number("terminal");
    const auto d = num_array(s.at("desired_approach"), 3, s.path("desired_approach"));
    c.reward.desired_approach = Eigen::Vector3d(d[0], d[1], d[2]);
    s.finish();
  }
  {
    ConfigReader s(r.at("constraints"), r.path("constraints"));
    c.joint = read_group(s.at("joint"), 2 * kArmJoints, s.path("joint"));
    c.obstacle = read_group(s.at("obstacle"), kArmPoi, s.path("obstacle"));
    c.body = read_group(s.at("body"), kArmPoi, s.path("body"));
    c.ground = read_group(s.at("ground"), 2, s.path("ground"));
    const json& gp = s.at("ground_poi");
    if (!gp.is_array() || gp.size() != 2)
      throw std::invalid_argument("config key '" + s.path("ground_poi") + "' must be a list of 2 PoI indices");
    for (int i = 0; i < 2; ++i)
      c.ground_poi[size_t(i)] = checked_number(gp[size_t(i)], "config key '" + s.path("ground_poi") + "[" +
                                                                  std::to_string(i) + "]'",
                                               range::closed(0, kArmPoi - 1));
    s.finish();
  }
  c.init_margin = r.number("init_margin", range::non_negative());
  c.sample_batches = r.integer("sample_batches", range::closed(1, 100000));
  c.goal_min_distance = r.number("goal_min_distance", range::non_negative());
  c.goal_library_size = r.integer("goal_library_size", range::closed(1, 1 << 20));
  c.goal_library_seed = r.integer("goal_library_seed", range::all<uint64_t>());
  c.goal_jitter = r.number("goal_jitter", range::closed_open(0.0, 1.0));
  const auto h = num_array(r.at("home"), kArmJoints, r.path("home"));
  std::copy(h.begin(), h.end(), c.home.begin());
  c.sdf.clear();
  if (j.contains("sdf")) {
    const json& sd = r.at("sdf");
    if (!sd.is_object()) throw std::invalid_argument("config key 'env.sdf' must be an object {object: analytic | learned | learned:<dir>}");
    for (const auto& [k, v] : sd.items()) {
      if (!v.is_string()) throw std::invalid_argument("config key 'env.sdf." + k + "' must be a string");
      c.sdf[k] = v.get<std::string>();
    }
  }
  r.finish();
  c.validate();
}

// ---------------------------------------------------------------- env

struct ArmEnv::Kernel {
  lanes::ArmKernelConst k;
  std::shared_ptr<LearnedObstacle> learned;  // the obstacle's learned field, or null (analytic)
  explicit Kernel(const TiagoArmModel& m) : k(m) {}
};

ArmEnv::ArmEnv(const ArmEnvConfig& config, int num_envs) : config_(config) {
  config_.validate();
  if (num_envs < 1) throw std::invalid_argument("number of envs must be >= 1");
  config_.reward.desired_approach.normalize();
  model_ = load_tiago_arm_model(config_.torso_lift);
  scene_ = build_arm_scene(config_.scene, model_);
  vmax_.resize(kArmJoints);
  for (int j = 0; j < kArmJoints; ++j) vmax_[j] = config_.velocity_scale * model_.velocity[j];

  auto kern = std::make_shared<Kernel>(model_);
  lanes::ArmKernelConst& k = kern->k;
  k.obstacle = scene_.obstacle.shapes;
  k.body = scene_.body.shapes;
  k.obstacle_blend = scene_.obstacle.blend;
  k.body_blend = scene_.body.blend;
  k.obstacle_bounds = Shape::box(scene_.obstacle_bounds.center(),
                                 0.5 * (scene_.obstacle_bounds.max - scene_.obstacle_bounds.min), "bounds");
  for (int j = 0; j < kArmJoints; ++j) {
    k.q_lo[j] = model_.lower[j] + config_.joint.margin[j];
    k.q_hi[j] = model_.upper[j] - config_.joint.margin[kArmJoints + j];
    k.q_min[j] = model_.lower[j];
    k.q_max[j] = model_.upper[j];
    if (!(k.q_lo[j] < k.q_hi[j])) throw std::invalid_argument("joint margins leave no room for joint " + std::to_string(j));
    row_offset_[kRowJointLower + j] = k.q_lo[j];
    row_offset_[kRowJointUpper + j] = k.q_hi[j];
  }
  kern->learned = load_arm_learned_obstacle(config_.sdf, config_.scene);
  k.learned_obstacle = kern->learned.get();
  for (int i = 0; i < kArmPoi; ++i) {
    k.delta_obstacle[i] = model_.scene_cover[i] + config_.obstacle.margin[i] + (kern->learned ? kern->learned->margin : 0.0);
    k.delta_body[i] = model_.body_cover[i] + config_.body.margin[i];
    row_offset_[kRowScene + i] = k.delta_obstacle[i];
    row_offset_[kRowBody + i] = k.delta_body[i];
  }
  for (int r = 0; r < 2; ++r) {
    k.ground_poi[r] = config_.ground_poi[r];
    k.ground_h[r] = config_.ground.margin[r];
    row_offset_[kRowGround + r] = k.ground_h[r];
  }
  for (const ArmCapsule& cap : model_.capsules) {
    lanes::ArmGtItem it;
    it.frame = cap.frame;
    for (int r = 0; r < 3; ++r) {
      it.a[r] = cap.a(r);
      it.b[r] = cap.b(r);
    }
    it.radius = cap.radius;
    it.half_length = 0.5 * (cap.b - cap.a).norm();
    it.body_check = cap.body_check;
    k.items.push_back(it);
  }
  for (const ArmPoi& p : model_.poi) {
    if (p.inside_capsule) continue;  // covered by a capsule item (the reference still checks it)
    lanes::ArmGtItem it;
    it.frame = p.frame;
    for (int r = 0; r < 3; ++r) it.a[r] = it.b[r] = p.offset(r);
    it.radius = p.radius;
    it.body_check = p.body_check;
    k.items.push_back(it);
  }
  kernel_ = kern;

  // The fallback start must be safe, or resets could start inside the constraints.
  const ArmEval home = evaluate_reference(config_.home.data());
  if (home.c.maxCoeff() > -config_.init_margin || home.collision)
    throw std::invalid_argument("config.home is not a safe start (max constraint " + std::to_string(home.c.maxCoeff()) +
                                (home.collision ? ", in collision" : "") + "); choose another home configuration");

  build_goal_library();
  build_spec();
  const size_t N = static_cast<size_t>(num_envs);
  q_.assign(N * kArmJoints, 0.0);
  goal_.assign(N * 3, 0.0);
  t_.assign(N, 0);
  ret_.assign(N, 0.0);
  rng_.assign(N, Rng());
  fallback_.assign(N, 0);
  c_.assign(N * kArmRows, 0.0);
  J_.assign(((N + kLanes - 1) / kLanes) * kLanes * kArmDynamicRows * kArmJoints, 0.0);
  grasp_.assign(N * 3, 0.0);
  approach_.assign(N * 3, 0.0);
  buffers_.resize(spec_, num_envs);
  seed(0);
}

void ArmEnv::build_spec() {
  EnvSpec& s = spec_;
  s.name = arm_task_name(config_.task);
  s.obs_dim = kArmObsDim;
  s.act_dim = kArmJoints;
  s.dt = config_.dt;
  s.horizon = config_.horizon;
  s.gamma = 0.995;  // the task's discount (reference 5.3)
  s.num_constraints = kArmRows;
  s.obs_low.clear();
  s.obs_high.clear();
  for (int j = 0; j < kArmJoints; ++j) {
    s.obs_low.push_back(static_cast<float>(model_.lower[j]));
    s.obs_high.push_back(static_cast<float>(model_.upper[j]));
  }
  for (int r = 0; r < 3; ++r) {
    s.obs_low.push_back(static_cast<float>(scene_.goal_region.min(r)));
    s.obs_high.push_back(static_cast<float>(scene_.goal_region.max(r)));
  }
  for (int r = 0; r < 3; ++r) {  // the grasping frame stays within reach of the shoulder
    s.obs_low.push_back(static_cast<float>(model_.shoulder(r) - model_.reach));
    s.obs_high.push_back(static_cast<float>(model_.shoulder(r) + model_.reach));
  }
  for (int r = 0; r < 3; ++r) {
    s.obs_low.push_back(-1.0f);
    s.obs_high.push_back(1.0f);
  }
  s.constraint_names.clear();
  s.constraint_tolerance.clear();
  for (int j = 0; j < kArmJoints; ++j) {
    s.constraint_names.push_back(model_.joint_names[j] + "_lower");
    s.constraint_tolerance.push_back(config_.joint.tolerance[j]);
  }
  for (int j = 0; j < kArmJoints; ++j) {
    s.constraint_names.push_back(model_.joint_names[j] + "_upper");
    s.constraint_tolerance.push_back(config_.joint.tolerance[kArmJoints + j]);
  }
  for (int i = 0; i < kArmPoi; ++i) {
    s.constraint_names.push_back("obstacle_" + model_.poi[i].name);
    s.constraint_tolerance.push_back(config_.obstacle.tolerance[i]);
  }
  for (int i = 0; i < kArmPoi; ++i) {
    s.constraint_names.push_back("body_" + model_.poi[i].name);
    s.constraint_tolerance.push_back(config_.body.tolerance[i]);
  }
  for (int r = 0; r < 2; ++r) {
    s.constraint_names.push_back("ground_" + model_.poi[config_.ground_poi[r]].name);
    s.constraint_tolerance.push_back(config_.ground.tolerance[r]);
  }
  s.info_names = {"collision", "joint_limit_violation", "final_distance", "distance",
                  "angle",     "in_region",             "nan_action",     "reset_fallback"};
  s.info_reduce = {InfoReduce::Sum,  InfoReduce::Sum,  InfoReduce::Last, InfoReduce::Mean,
                   InfoReduce::Mean, InfoReduce::Mean, InfoReduce::Sum,  InfoReduce::Sum};
}

ProjectorModel ArmEnv::projector_model() const {
  ProjectorModel pm = default_projector_model(kArmJoints, kArmJoints, kArmRows, 0);
  auto fill = [&](const ArmRowGroup& g, int row0, int rows) {
    for (int r = 0; r < rows; ++r) {
      pm.slack[row0 + r] = SlackType::SoftCorner;
      pm.beta[row0 + r] = g.beta[r];
      pm.tol[row0 + r] = g.slack_tol;
    }
  };
  fill(config_.joint, kRowJointLower, 2 * kArmJoints);
  fill(config_.obstacle, kRowScene, kArmPoi);
  fill(config_.body, kRowBody, kArmPoi);
  fill(config_.ground, kRowGround, 2);
  pm.K_c = 1.0 / config_.dt;
  pm.basis = BasisType::Projected;
  pm.g_form = GForm::Diagonal;
  pm.has_drift = false;
  pm.validate();
  return pm;
}

namespace {
// Joint-limit rows of J_q: -e_j (rows 0..6), +e_j (rows 7..13); constant.
struct JointRows {
  double v[kRowScene * kArmJoints];
  JointRows() {
    for (int j = 0; j < kArmJoints; ++j)
      for (int c = 0; c < kArmJoints; ++c) {
        v[(kRowJointLower + j) * kArmJoints + c] = c == j ? -1.0 : 0.0;
        v[(kRowJointUpper + j) * kArmJoints + c] = c == j ? 1.0 : 0.0;
      }
  }
};
const JointRows kJointRows;

// 8x8 transpose in registers: in[k][l] -> out[l][k].
inline void transpose8(const vd* in, vd* out) {
  using lanes::vm;
  const vm lo1 = {0, 8, 2, 10, 4, 12, 6, 14}, hi1 = {1, 9, 3, 11, 5, 13, 7, 15};
  const vm lo2 = {0, 1, 8, 9, 4, 5, 12, 13}, hi2 = {2, 3, 10, 11, 6, 7, 14, 15};
  const vm lo4 = {0, 1, 2, 3, 8, 9, 10, 11}, hi4 = {4, 5, 6, 7, 12, 13, 14, 15};
  vd t[8], u[8];
  for (int i = 0; i < 4; ++i) {
    t[2 * i] = __builtin_shuffle(in[2 * i], in[2 * i + 1], lo1);
    t[2 * i + 1] = __builtin_shuffle(in[2 * i], in[2 * i + 1], hi1);
  }
  for (int h = 0; h < 2; ++h) {  // rows 0-3 and 4-7
    const vd* q = t + 4 * h;
    u[4 * h + 0] = __builtin_shuffle(q[0], q[2], lo2);
    u[4 * h + 2] = __builtin_shuffle(q[0], q[2], hi2);
    u[4 * h + 1] = __builtin_shuffle(q[1], q[3], lo2);
    u[4 * h + 3] = __builtin_shuffle(q[1], q[3], hi2);
  }
  for (int i = 0; i < 4; ++i) {
    out[i] = __builtin_shuffle(u[i], u[4 + i], lo4);
    out[4 + i] = __builtin_shuffle(u[i], u[4 + i], hi4);
  }
}
}  // namespace

void ArmEnv::constraint_model(ProjectorBatch& pb, int begin, int end) const {
  constexpr int n = kArmJoints;
  constexpr int kDyn = kArmDynamicRows * n;  // 140 Jacobian entries per env from the lane-major cache
  for (int e = begin; e < end; ++e) {
    const size_t se = static_cast<size_t>(e);
    std::memcpy(&pb.c[se * kArmRows], &c_[se * kArmRows], sizeof(double) * kArmRows);
    std::memcpy(&pb.G[se * n], vmax_.data(), sizeof(double) * n);
    std::memcpy(&pb.Jq[se * kArmRows * n], kJointRows.v, sizeof kJointRows.v);
  }
  // Dynamic rows: whole lane groups by 8x8 register transposes, the rest
  // (partial groups at the range ends, the last 4 entries) element by element.
  int e = begin;
  while (e < end) {
    const size_t se = static_cast<size_t>(e);
    const double* Jg = &J_[(se / kLanes) * kLanes * kDyn];
    if (e % kLanes == 0 && e + kLanes <= end) {
      int k = 0;
      for (; k + kLanes <= kDyn; k += kLanes) {
        vd in[kLanes], out[kLanes];
        for (int r = 0; r < kLanes; ++r) in[r] = lanes::load(Jg + static_cast<size_t>(k + r) * kLanes);
        transpose8(in, out);
        for (int l = 0; l < kLanes; ++l) lanes::store(&pb.Jq[(se + l) * kArmRows * n + kRowScene * n + k], out[l]);
      }
      for (; k < kDyn; ++k)
        for (int l = 0; l < kLanes; ++l) pb.Jq[(se + l) * kArmRows * n + kRowScene * n + k] = Jg[k * kLanes + l];
      e += kLanes;
    } else {
      const double* Jl = Jg + se % kLanes;
      for (int k = 0; k < kDyn; ++k) pb.Jq[se * kArmRows * n + kRowScene * n + k] = Jl[k * kLanes];
      ++e;
    }
  }
}

void ArmEnv::set_profiling(bool on) {
  profiling_ = on;
  for (auto& p : prof_ns_) p.store(0);
}

std::vector<double> ArmEnv::profile_seconds() const {
  return {prof_ns_[0].load() * 1e-9, prof_ns_[1].load() * 1e-9, prof_ns_[2].load() * 1e-9};
}

void ArmEnv::write_obs(int e, float* obs) const {
  const size_t se = static_cast<size_t>(e);
  for (int j = 0; j < kArmJoints; ++j) obs[j] = static_cast<float>(q_[se * kArmJoints + j]);
  for (int r = 0; r < 3; ++r) {
    obs[7 + r] = static_cast<float>(goal_[se * 3 + r]);
    obs[10 + r] = static_cast<float>(grasp_[se * 3 + r]);
    obs[13 + r] = static_cast<float>(approach_[se * 3 + r]);
  }
}

namespace {
// Copy lane l of a kernel evaluation into env e's cached model. J is the
// env's lane group in the lane-major Jacobian cache (element-major, lane-minor).
void store_lane(const lanes::ArmFkLanes& fk, const lanes::ArmKernelOut& o, int l, int e, double* c, double* J_cache,
                double* grasp, double* approach, bool with_jacobian = true) {
  for (int r = 0; r < kArmRows; ++r) c[r] = o.c[r][l];
  if (with_jacobian) {
    double* J = J_cache + static_cast<size_t>(e / kLanes) * kLanes * kArmDynamicRows * kArmJoints + e % kLanes;
    for (int r = 0; r < kArmDynamicRows; ++r)
      for (int j = 0; j < kArmJoints; ++j) J[(r * kArmJoints + j) * kLanes] = o.J[r][j][l];
  }
  for (int r = 0; r < 3; ++r) {
    grasp[r] = fk.grasp_p[r][l];
    approach[r] = o.approach[r][l];
  }
}
}  // namespace

void ArmEnv::refresh(int e) {
  const lanes::ArmKernelConst& k = kernel_->k;
  vd ql[kArmJoints];
  for (int j = 0; j < kArmJoints; ++j) ql[j] = lanes::splat(q_[static_cast<size_t>(e) * kArmJoints + j]);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  const size_t se = static_cast<size_t>(e);
  store_lane(fk, o, 0, e, &c_[se * kArmRows], J_.data(), &grasp_[se * 3], &approach_[se * 3]);
  write_obs(e, &buffers_.obs[se * kArmObsDim]);
}

void ArmEnv::reset_env(int e) {
  const lanes::ArmKernelConst& k = kernel_->k;
  Rng& rng = rng_[e];
  const size_t se = static_cast<size_t>(e);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const double need = -config_.init_margin;
  auto lane_ok = [&](int l) {
    if (o.collision[l] || o.joint_violation[l]) return false;
    for (int r = 0; r < kArmRows; ++r)
      if (!(o.c[r][l] <= need)) return false;
    return true;
  };
  auto draw = [&]() {
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(k.q_lo[j], k.q_hi[j]);
  };
  // Initial state: first safe candidate in draw order (deterministic per env).
  bool found = false;
  for (int b = 0; b < config_.sample_batches && !found; ++b) {
    draw();
    lanes::arm_fk_lanes(k.fk, ql, fk, true);
    lanes::arm_constraints_lanes(k, ql, fk, o, true);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && !found; ++l)
      if (lane_ok(l)) {
        for (int j = 0; j < kArmJoints; ++j) q_[se * kArmJoints + j] = ql[j][l];
        store_lane(fk, o, l, e, &c_[se * kArmRows], J_.data(), &grasp_[se * 3], &approach_[se * 3]);
        found = true;
      }
  }
  uint8_t fb = 0;
  if (!found) {
    std::copy(config_.home.begin(), config_.home.end(), &q_[se * kArmJoints]);
    refresh(e);
    fb = 1;
  }
  const Eigen::Vector3d start(grasp_[se * 3], grasp_[se * 3 + 1], grasp_[se * 3 + 2]);
  if (!sample_goal(e, start.data(), &goal_[se * 3])) fb = 1;
  fallback_[e] = fb;
  t_[e] = 0;
  ret_[e] = 0.0;
  write_obs(e, &buffers_.obs[se * kArmObsDim]);
}

// Goal: grasping-frame position of a safe configuration inside the goal
// region (so every goal is reachable without touching a constraint): a
// library configuration, jittered so that goals cover the region densely.
bool ArmEnv::sample_goal(int e, const double* away_from, double* goal) {
  const lanes::ArmKernelConst& k = kernel_->k;
  Rng& rng = rng_[e];
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const Eigen::Vector3d start(away_from[0], away_from[1], away_from[2]);
  const int L = static_cast<int>(goal_lib_q_.size() / kArmJoints);
  int base = 0;
  for (int b = 0; b < config_.sample_batches; ++b) {
    base = static_cast<int>(rng.below(static_cast<uint64_t>(L)));
    const double* qb = &goal_lib_q_[static_cast<size_t>(base) * kArmJoints];
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j)
        ql[j][l] = std::clamp(qb[j] + config_.goal_jitter * rng.uniform(-1.0, 1.0), k.q_lo[j], k.q_hi[j]);
    lanes::arm_fk_lanes(k.fk, ql, fk, false);
    lanes::arm_constraints_lanes(k, ql, fk, o, false);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes; ++l) {
      const Eigen::Vector3d g(fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]);
      if (!scene_.goal_region.contains(g) || (g - start).norm() < config_.goal_min_distance) continue;
      if (o.collision[l] || o.joint_violation[l]) continue;
      bool ok = true;
      for (int r = 0; r < kArmRows; ++r) ok = ok && o.c[r][l] <= -config_.init_margin;
      if (!ok) continue;
      for (int r = 0; r < 3; ++r) goal[r] = g(r);
      return true;
    }
  }
  // Fallback: the last library configuration itself (safe, inside the region).
  const ArmFkResult r = arm_fk_reference(model_, Eigen::Map<const ArmQ>(&goal_lib_q_[static_cast<size_t>(base) * kArmJoints]));
  for (int c = 0; c < 3; ++c) goal[c] = r.grasp.p(c);
  return false;
}

void ArmEnv::build_goal_library() {
  const lanes::ArmKernelConst& k = kernel_->k;
  Rng rng(config_.goal_library_seed, 0);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const int want = config_.goal_library_size;
  goal_lib_q_.clear();
  // Candidates are uniform in the joint box; cheap FK first, constraints and
  // ground truth only for candidates whose grasping frame is in the region.
  const int64_t max_batches = 4096 + 2000 * static_cast<int64_t>(want);
  for (int64_t b = 0; b < max_batches && static_cast<int>(goal_lib_q_.size()) < want * kArmJoints; ++b) {
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(k.q_lo[j], k.q_hi[j]);
    lanes::arm_fk_lanes(k.fk, ql, fk, false);
    bool in[kLanes], any_in = false;
    for (int l = 0; l < kLanes; ++l) {
      in[l] = scene_.goal_region.contains({fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]});
      any_in = any_in || in[l];
    }
    if (!any_in) continue;
    lanes::arm_constraints_lanes(k, ql, fk, o, false);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && static_cast<int>(goal_lib_q_.size()) < want * kArmJoints; ++l) {
      if (!in[l] || o.collision[l] || o.joint_violation[l]) continue;
      bool ok = true;
      for (int r = 0; r < kArmRows; ++r) ok = ok && o.c[r][l] <= -config_.init_margin;
      if (ok)
        for (int j = 0; j < kArmJoints; ++j) goal_lib_q_.push_back(ql[j][l]);
    }
  }
  if (goal_lib_q_.empty())
    throw std::invalid_argument("scene.goal_region: no safe configuration puts the grasping frame there "
                                "(region unreachable under the constraints)");
}

void ArmEnv::seed(uint64_t seed) {
  seed_ = seed;
  for (size_t i = 0; i < rng_.size(); ++i) rng_[i].reseed(seed, i);
  reset(nullptr);
}

void ArmEnv::reset(const uint8_t* mask) {
  const int N = num_envs();
  parallel_blocks(N, kBlockEnvs, [&](int64_t lo, int64_t hi) {
    for (int64_t e = lo; e < hi; ++e) {
      if (mask && !mask[e]) continue;
      reset_env(static_cast<int>(e));
      const size_t se = static_cast<size_t>(e);
      std::memcpy(&buffers_.final_obs[se * kArmObsDim], &buffers_.obs[se * kArmObsDim], sizeof(float) * kArmObsDim);
      std::memcpy(&buffers_.constraints[se * kArmRows], &c_[se * kArmRows], sizeof(double) * kArmRows);
      buffers_.reward[e] = 0.0f;
      buffers_.cost[e] = 0.0f;
      buffers_.terminated[e] = buffers_.truncated[e] = 0;
      for (int c = 0; c < kInfoCount; ++c) buffers_.info[se * kInfoCount + c] = 0.0f;
    }
  });
}

void ArmEnv::step(const double* actions) {
  const int N = num_envs();
  parallel_blocks(N, kBlockEnvs, [&](int64_t lo, int64_t hi) {
    for (int64_t e0 = lo; e0 < hi; e0 += kLanes) {
      const int cnt = static_cast<int>(std::min<int64_t>(kLanes, hi - e0));
      eval_group(static_cast<int>(e0), cnt, actions);
    }
  });
}

void ArmEnv::eval_group(int e0, int cnt, const double* actions) {
  const lanes::ArmKernelConst& k = kernel_->k;
  const bool prof = profiling_;
  const int64_t t0 = prof ? now_ns() : 0;
  double anorm[kLanes] = {};
  int nan_count[kLanes] = {};
  // 1. Integrate qdot = diag(vmax) a exactly over dt (a is constant in the step).
  vd ql[kArmJoints];
  for (int l = 0; l < cnt; ++l) {
    const size_t e = static_cast<size_t>(e0 + l);
    double s2 = 0.0;
    for (int j = 0; j < kArmJoints; ++j) {
      double a = actions[e * kArmJoints + j];
      if (!std::isfinite(a)) {  // NaN / Inf: treated as 0 and counted
        a = 0.0;
        ++nan_count[l];
      }
      a = std::clamp(a, -1.0, 1.0);
      s2 += a * a;
      q_[e * kArmJoints + j] += config_.dt * vmax_[j] * a;
    }
    anorm[l] = std::sqrt(s2);
  }
  for (int j = 0; j < kArmJoints; ++j)
    ql[j] = lanes::load_strided(&q_[static_cast<size_t>(e0) * kArmJoints + j], kArmJoints, cnt);
  // 2. Kinematics, constraints and ground truth of the reached state.
  const int64_t t1 = prof ? now_ns() : 0;
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  const int64_t t2 = prof ? now_ns() : 0;
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  lanes::arm_ground_truth_lanes(k, ql, fk, o, cnt);
  const int64_t t3 = prof ? now_ns() : 0;
  // 3. Reward, termination, observation, autoreset.
  EnvBuffers& B = buffers_;
  const ArmRewardConfig& rw = config_.reward;
  // Jacobians of the whole lane group in one go (e0 is a multiple of kLanes;
  // lanes past N are padding). Resets below overwrite their own lane.
  {
    double* Jg = &J_[static_cast<size_t>(e0) * kArmDynamicRows * kArmJoints];
    for (int r = 0; r < kArmDynamicRows; ++r)
      for (int j = 0; j < kArmJoints; ++j) lanes::store(Jg + (r * kArmJoints + j) * kLanes, o.J[r][j]);
  }
  for (int l = 0; l < cnt; ++l) {
    const int ei = e0 + l;
    const size_t e = static_cast<size_t>(ei);
    store_lane(fk, o, l, ei, &c_[e * kArmRows], J_.data(), &grasp_[e * 3], &approach_[e * 3], false);
    const Eigen::Vector3d g(grasp_[e * 3], grasp_[e * 3 + 1], grasp_[e * 3 + 2]);
    const Eigen::Vector3d goal(goal_[e * 3], goal_[e * 3 + 1], goal_[e * 3 + 2]);
    const Eigen::Vector3d ax(approach_[e * 3], approach_[e * 3 + 1], approach_[e * 3 + 2]);
    const double dist = (g - goal).norm();
    const double ang = std::acos(std::clamp(ax.dot(rw.desired_approach), -1.0, 1.0));
    const bool in_region = scene_.indicator_region.contains(g);
    const bool term = o.collision[l] || o.joint_violation[l];
    ++t_[ei];
    const bool trunc = !term && t_[ei] >= config_.horizon;
    const double r = term ? rw.terminal
                          : -rw.rho_d * dist - rw.rho_ang * ang - rw.rho_a * anorm[l] + (in_region ? rw.indicator : 0.0);
    ret_[ei] += r;
    double cmax = -1e300;
    for (int row = 0; row < kArmRows; ++row) cmax = std::max(cmax, c_[e * kArmRows + row]);
    std::memcpy(&B.constraints[e * kArmRows], &c_[e * kArmRows], sizeof(double) * kArmRows);
    B.reward[e] = static_cast<float>(r);
    B.cost[e] = static_cast<float>(std::max(0.0, cmax));
    B.terminated[e] = term;
    B.truncated[e] = trunc;
    float* info = &B.info[e * kInfoCount];
    info[kInfoCollision] = o.collision[l] ? 1.0f : 0.0f;
    info[kInfoJointViolation] = o.joint_violation[l] ? 1.0f : 0.0f;
    info[kInfoFinalDistance] = static_cast<float>(dist);
    info[kInfoDistance] = static_cast<float>(dist);
    info[kInfoAngle] = static_cast<float>(ang);
    info[kInfoInRegion] = in_region ? 1.0f : 0.0f;
    info[kInfoNanAction] = static_cast<float>(nan_count[l]);
    info[kInfoResetFallback] = 0.0f;
    float* fobs = &B.final_obs[e * kArmObsDim];
    write_obs(ei, fobs);
    if (term || trunc) {
      B.episode_return[e] = ret_[ei];
      B.episode_length[e] = t_[ei];
      reset_env(ei);
      info[kInfoResetFallback] = fallback_[ei];
    } else {
      std::memcpy(&B.obs[e * kArmObsDim], fobs, sizeof(float) * kArmObsDim);
    }
  }
  if (prof) {
    const int64_t t4 = now_ns();
    prof_ns_[0].fetch_add(t2 - t1, std::memory_order_relaxed);
    prof_ns_[1].fetch_add(t3 - t2, std::memory_order_relaxed);
    prof_ns_[2].fetch_add((t1 - t0) + (t4 - t3), std::memory_order_relaxed);
  }
}

ArmEval ArmEnv::evaluate_reference(const double* q) const {
  ArmEval ev;
  const ArmFkResult fk = arm_fk_reference(model_, Eigen::Map<const ArmQ>(q));
  ev.c.setZero();
  ev.J.setZero();
  for (int j = 0; j < kArmJoints; ++j) {
    ev.c(kRowJointLower + j) = row_offset_[kRowJointLower + j] - q[j];
    ev.J(kRowJointLower + j, j) = -1.0;
    ev.c(kRowJointUpper + j) = q[j] - row_offset_[kRowJointUpper + j];
    ev.J(kRowJointUpper + j, j) = 1.0;
    ev.joint_violation = ev.joint_violation || q[j] < model_.lower[j] || q[j] > model_.upper[j];
  }
  for (int i = 0; i < kArmPoi; ++i) {
    Eigen::Vector3d g;
    const double d_obs = union_distance(scene_.obstacle, fk.poi[i], &g);
    ev.c(kRowScene + i) = row_offset_[kRowScene + i] - d_obs;
    ev.J.row(kRowScene + i) = -(g.transpose() * fk.J_poi[i]);
    const double d_body = union_distance(scene_.body, fk.poi[i], &g);
    ev.c(kRowBody + i) = row_offset_[kRowBody + i] - d_body;
    ev.J.row(kRowBody + i) = -(g.transpose() * fk.J_poi[i]);
  }
  for (int r = 0; r < 2; ++r) {
    const int i = config_.ground_poi[r];
    ev.c(kRowGround + r) = row_offset_[kRowGround + r] - fk.poi[i].z();
    ev.J.row(kRowGround + r) = -fk.J_poi[i].row(2);
  }
  ev.grasp_p = fk.grasp.p;
  ev.approach = fk.grasp.R.col(0);
  // Ground truth: every capsule and PoI sphere against floor, obstacle, body.
  auto check = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius, bool body) {
    if (std::min(a.z(), b.z()) < radius) return true;
    for (const Shape& s : scene_.obstacle.shapes)
      if (segment_distance(s, a, b) < radius) return true;
    if (body)
      for (const Shape& s : scene_.body.shapes)
        if (segment_distance(s, a, b) < radius) return true;
    return false;
  };
  for (const ArmCapsule& cap : model_.capsules)
    ev.collision = ev.collision ||
                   check(fk.frame[cap.frame].apply(cap.a), fk.frame[cap.frame].apply(cap.b), cap.radius, cap.body_check);
  for (int i = 0; i < kArmPoi; ++i)
    ev.collision = ev.collision || check(fk.poi[i], fk.poi[i], model_.poi[i].radius, model_.poi[i].body_check);
  return ev;
}

void ArmEnv::set_state(int i, const double* q, const double* goal) {
  const size_t se = static_cast<size_t>(i);
  std::copy(q, q + kArmJoints, &q_[se * kArmJoints]);
  std::copy(goal, goal + 3, &goal_[se * 3]);
  t_[i] = 0;
  ret_[i] = 0.0;
  refresh(i);
}

void ArmEnv::set_goal(int i, const double* goal) {
  std::copy(goal, goal + 3, &goal_[static_cast<size_t>(i) * 3]);
  write_obs(i, &buffers_.obs[static_cast<size_t>(i) * kArmObsDim]);
}

// Snapshot: every per-env state vector and RNG stream; the cached model is
// recomputed from q on load (a pure function of q, so bit-identical).
void ArmEnv::save_state(std::ostream& out) const {
  const int32_t N = num_envs();
  out.write(reinterpret_cast<const char*>(&N), sizeof N);
  out.write(reinterpret_cast<const char*>(&seed_), sizeof seed_);
  auto put = [&](const auto& v) { out.write(reinterpret_cast<const char*>(v.data()), sizeof(v[0]) * v.size()); };
  put(q_);
  put(goal_);
  put(t_);
  put(ret_);
  put(fallback_);
  for (const Rng& r : rng_) {
    const Rng::State st = r.state();
    out.write(reinterpret_cast<const char*>(&st), sizeof st);
  }
  put(c_);
  put(J_);
  put(grasp_);
  put(approach_);
  put(buffers_.obs);
}

void ArmEnv::load_state(std::istream& in) {
  int32_t N = 0;
  in.read(reinterpret_cast<char*>(&N), sizeof N);
  if (!in || N != num_envs())
    throw std::runtime_error("arm env snapshot holds " + std::to_string(N) + " envs, this env has " +
                             std::to_string(num_envs()));
  in.read(reinterpret_cast<char*>(&seed_), sizeof seed_);
  auto get = [&](auto& v) { in.read(reinterpret_cast<char*>(v.data()), sizeof(v[0]) * v.size()); };
  get(q_);
  get(goal_);
  get(t_);
  get(ret_);
  get(fallback_);
  for (Rng& r : rng_) {
    Rng::State st;
    in.read(reinterpret_cast<char*>(&st), sizeof st);
    r.set_state(st);
  }
  get(c_);
  get(J_);
  get(grasp_);
  get(approach_);
  get(buffers_.obs);
  if (!in) throw std::runtime_error("arm env snapshot is truncated");
}

}  // namespace atacom
