// The manipulation envs' static model: kernel tables and row offsets from
// the config, the goal library, the spec and the projector model.
#include "envs/arm/arm_model.hpp"

#include <cmath>
#include <map>
#include <mutex>
#include <stdexcept>

#include "envs/arm/arm_kernels.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/env_target.hpp"

namespace atacom {

using lanes::kLanes;
using lanes::vd;

namespace {
// The human's data, loaded once per process and shared by every HRI model.
struct HumanData {
  HumanModel model = load_human_model();
  HumanMotionLibrary motion = load_default_human_motion();
};
const HumanData& human_data() {
  static const HumanData d;
  return d;
}

ArmEnvConfig validated(const ArmEnvConfig& c) {
  c.validate();
  ArmEnvConfig v = c;
  v.reward.desired_approach.normalize();
  if (v.task == ArmTask::Hri) v.hri.cup_axis.normalize();
  return v;
}
}  // namespace

ArmModel::ArmModel(const ArmEnvConfig& cfg)
    : config(validated(cfg)),
      robot(load_tiago_arm_model(config.torso_lift)),
      scene(build_arm_scene(config.scene, robot)),
      rows(ArmRowLayout::compose(config.task == ArmTask::Hri, config.task == ArmTask::Hri && config.hri.upright_row)),
      kern(robot) {
  k = rows.k;
  dyn = rows.dynamic_rows();
  obs_dim = hri() ? kHriObsDim : kArmObsDim;
  info_count = hri() ? kInfoCountHri : kInfoCount;
  vmax.resize(kArmJoints);
  for (int j = 0; j < kArmJoints; ++j) vmax[j] = config.velocity_scale * robot.velocity[j];
  build_kernel_tables();
  // The fallback start must be safe against the static rows (HRI: the human
  // moves, so it is checked per reset), or resets could start inside the constraints.
  const ArmEval home = evaluate_reference(*this, config.home.data());
  if (home.c.maxCoeff() > -config.init_margin || home.collision)
    throw std::invalid_argument("config.home is not a safe start (max constraint " + std::to_string(home.c.maxCoeff()) +
                                (home.collision ? ", in collision" : "") + "); choose another home configuration");
  build_libraries();
  build_spec();
}

namespace {
// The goal and start libraries are a function of the validated config and
// the learned fields' weights (each library has its own seed), and sampling
// them is most of an hri env's construction (0.3 s in Release, 6 s under the
// sanitizers): a process samples each once. The key holds the config's JSON
// and a hash of every learned field, so a field retrained into the same
// directory is a new key; the robot and human data are shipped files, read
// once per process anyway. The copies kept are bounded in bytes (a library
// may hold 2^20 goals, 136 MB): at most kMaxBytes, the cache emptied when full.
struct Libraries {
  std::vector<double> goal_q, start_q;
  std::vector<Eigen::Vector3d> goal_p;
};
constexpr size_t kMaxBytes = size_t(64) << 20;
std::mutex libraries_mutex;
size_t cached_bytes = 0;  // guarded by libraries_mutex
std::map<std::string, std::shared_ptr<const Libraries>>& library_cache() {
  static std::map<std::string, std::shared_ptr<const Libraries>> cache;
  return cache;
}

void hash_field(uint64_t& h, const RedsdfModel* m, double margin, const double* extra, size_t n_extra) {
  if (m == nullptr) {
    h = bin::fnv1a("-", 1, h);
    return;
  }
  const std::string manifest = m->manifest.dump();
  h = bin::fnv1a(manifest.data(), manifest.size(), h);
  h = bin::fnv1a(m->params.data(), m->params.size() * sizeof(float), h);
  h = bin::fnv1a(&margin, sizeof margin, h);
  h = bin::fnv1a(extra, n_extra * sizeof(double), h);
}
}  // namespace

void ArmModel::build_libraries() {
  uint64_t h = bin::kFnv1aSeed;
  for (const LearnedObstacle* f : {learned.get(), learned_body.get()}) {
    if (f == nullptr) {
      hash_field(h, nullptr, 0.0, nullptr, 0);
      continue;
    }
    std::vector<double> frame(f->R.data(), f->R.data() + 9);
    frame.insert(frame.end(), f->t.data(), f->t.data() + 3);
    for (float x : f->pose) frame.push_back(double(x));
    hash_field(h, f->model.get(), f->margin, frame.data(), frame.size());
  }
  hash_field(h, learned_human ? learned_human->model.get() : nullptr, learned_human ? learned_human->margin : 0.0,
             nullptr, 0);
  const std::string key = std::to_string(int(config.task)) + "#" + nlohmann::json(config).dump() + "#" + std::to_string(h);
  {
    std::lock_guard<std::mutex> lock(libraries_mutex);
    const auto it = library_cache().find(key);
    if (it != library_cache().end()) {
      goal_lib_q = it->second->goal_q;
      goal_lib_p = it->second->goal_p;
      start_lib_q = it->second->start_q;
      return;
    }
  }
  build_goal_library();
  build_start_library();
  const size_t bytes = (goal_lib_q.size() + start_lib_q.size()) * sizeof(double) +
                       goal_lib_p.size() * sizeof(Eigen::Vector3d) + key.size();
  if (bytes > kMaxBytes) return;
  auto entry = std::make_shared<Libraries>();
  entry->goal_q = goal_lib_q;
  entry->goal_p = goal_lib_p;
  entry->start_q = start_lib_q;
  std::lock_guard<std::mutex> lock(libraries_mutex);
  if (cached_bytes + bytes > kMaxBytes) {
    library_cache().clear();
    cached_bytes = 0;
  }
  if (library_cache().emplace(key, std::move(entry)).second) cached_bytes += bytes;
}

void ArmModel::build_kernel_tables() {
  lanes::ArmKernelConst& kc = kern;
  kc.obstacle = scene.obstacle.shapes;
  kc.body = scene.body.shapes;
  kc.obstacle_blend = scene.obstacle.blend;
  kc.body_blend = scene.body.blend;
  kc.obstacle_bounds = Shape::box(scene.obstacle_bounds.center(),
                                  0.5 * (scene.obstacle_bounds.max - scene.obstacle_bounds.min), "bounds");
  for (int j = 0; j < kArmJoints; ++j) {
    kc.q_lo[j] = robot.lower[j] + config.joint.margin[j];
    kc.q_hi[j] = robot.upper[j] - config.joint.margin[kArmJoints + j];
    kc.q_min[j] = robot.lower[j];
    kc.q_max[j] = robot.upper[j];
    if (!(kc.q_lo[j] < kc.q_hi[j]))
      throw std::invalid_argument("joint margins leave no room for joint " + std::to_string(j));
    row_offset[kRowJointLower + j] = kc.q_lo[j];
    row_offset[kRowJointUpper + j] = kc.q_hi[j];
  }
  learned = load_arm_learned_obstacle(config.sdf, config.scene);
  kc.learned_obstacle = learned.get();
  learned_body = load_arm_learned_body(config.sdf, config.torso_lift);
  kc.learned_body = learned_body.get();
  for (int i = 0; i < kArmPoi; ++i) {
    kc.delta_obstacle[i] = robot.scene_cover[i] + config.obstacle.margin[i] + (learned ? learned->margin : 0.0);
    kc.delta_body[i] = robot.body_cover[i] + config.body.margin[i] + (learned_body ? learned_body->margin : 0.0);
    row_offset[kRowScene + i] = kc.delta_obstacle[i];
    row_offset[kRowBody + i] = kc.delta_body[i];
  }
  for (int r = 0; r < 2; ++r) {
    kc.ground_poi[r] = config.ground_poi[r];
    kc.ground_h[r] = config.ground.margin[r];
    row_offset[kRowGround + r] = kc.ground_h[r];
  }
  for (const ArmCapsule& cap : robot.capsules) {
    lanes::ArmGtItem it;
    it.frame = cap.frame;
    for (int r = 0; r < 3; ++r) {
      it.a[r] = cap.a(r);
      it.b[r] = cap.b(r);
    }
    it.radius = cap.radius;
    it.half_length = 0.5 * (cap.b - cap.a).norm();
    it.body_check = cap.body_check;
    kc.items.push_back(it);
  }
  for (const ArmPoi& p : robot.poi) {
    if (p.inside_capsule) continue;  // covered by a capsule item (the reference still checks it)
    lanes::ArmGtItem it;
    it.frame = p.frame;
    for (int r = 0; r < 3; ++r) it.a[r] = it.b[r] = p.offset(r);
    it.radius = p.radius;
    it.body_check = p.body_check;
    kc.items.push_back(it);
  }
  if (!hri()) return;
  const ArmHriConfig& h = config.hri;
  human = &human_data().model;
  motion = &human_data().motion;
  std::vector<double> delta(kArmPoi);
  learned_human = load_arm_learned_human(config.sdf);
  kc.learned_human = learned_human.get();
  const double learned_margin = learned_human ? learned_human->margin : 0.0;
  for (int i = 0; i < kArmPoi; ++i) {
    delta[size_t(i)] = robot.scene_cover[i] + h.human.margin[size_t(i)] + learned_margin;
    row_offset_hri[size_t(i)] = delta[size_t(i)];
  }
  human_rows = make_human_rows(delta, kArmJoints, h.human_blend);
  kc.hri = true;
  kc.human = human_rows;
  kc.human_fk = &human->fk;
  for (int r = 0; r < 3; ++r) kc.cup_axis[r] = h.cup_axis(r);
  kc.cos_upright = std::cos(h.theta_max - h.upright.margin[0]);
  row_offset_hri[kArmPoi] = kc.cos_upright;
  cos_start_tilt = std::cos(h.start_tilt);
  replay.frames_per_step = h.frames_per_step;
  replay.split = h.split;
  for (const lanes::ArmGtItem& it : kc.items) robot_radii.push_back(it.radius);
}

bool ArmModel::static_rows_ok(const lanes::ArmKernelOut& o, int l) const {
  bool ok = true;
  for (const ArmRowSpan& g : rows.groups) {
    if (g.moving) continue;
    for (int r = g.begin; r < g.begin + g.count; ++r) ok = ok && o.c[r][l] <= -config.init_margin;
  }
  return ok;
}

bool ArmModel::pose_ok(const lanes::ArmKernelOut& o, int l) const { return static_rows_ok(o, l) && cup_upright(o, l); }

bool ArmModel::in_goal_region(const Eigen::Vector3d& g) const {
  if (!hri()) return scene.goal_region.contains(g);
  for (const AlignedBox& b : config.hri.targets)
    if (b.contains(g)) return true;
  return false;
}

void ArmModel::build_goal_library() {
  const lanes::ArmKernelConst& kc = kern;
  Rng rng(config.goal_library_seed, 0);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const int want = config.goal_library_size;
  // Candidates are uniform in the joint box; cheap FK first, constraints and
  // ground truth only for candidates whose grasping frame is in the region.
  const int64_t max_batches = 4096 + 2000 * static_cast<int64_t>(want);
  for (int64_t b = 0; b < max_batches && static_cast<int>(goal_lib_q.size()) < want * kArmJoints; ++b) {
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(kc.q_lo[j], kc.q_hi[j]);
    lanes::arm_fk_lanes(kc.fk, ql, fk, false);
    bool in[kLanes], any_in = false;
    for (int l = 0; l < kLanes; ++l) {
      in[l] = in_goal_region({fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]});
      any_in = any_in || in[l];
    }
    if (!any_in) continue;
    // The cup axis (and the upright row when composed) and the ground truth
    // need only FK: test them before the (learned) fields, which cost far
    // more. arm_constraints_lanes writes neither, so they stand for pose_ok.
    if (hri()) lanes::arm_upright_row_lanes(kc, fk, o, false);
    lanes::arm_ground_truth_lanes(kc, ql, fk, o, kLanes);
    any_in = false;
    for (int l = 0; l < kLanes; ++l)
      any_in = any_in || (in[l] && !o.collision[l] && !o.joint_violation[l] && cup_upright(o, l));
    if (!any_in) continue;
    lanes::arm_constraints_lanes(kc, ql, fk, o, false);
    for (int l = 0; l < kLanes && static_cast<int>(goal_lib_q.size()) < want * kArmJoints; ++l) {
      if (!in[l] || o.collision[l] || o.joint_violation[l]) continue;
      if (pose_ok(o, l)) {
        for (int j = 0; j < kArmJoints; ++j) goal_lib_q.push_back(ql[j][l]);
        goal_lib_p.emplace_back(double(fk.grasp_p[0][l]), double(fk.grasp_p[1][l]), double(fk.grasp_p[2][l]));
      }
    }
  }
  if (goal_lib_q.empty())
    throw std::invalid_argument("scene.goal_region: no safe configuration puts the grasping frame there "
                                "(region unreachable under the constraints)");
}

void ArmModel::build_start_library() {
  if (!(hri() && config.hri.start_tilt < kStartTiltUniform)) return;
  const lanes::ArmKernelConst& kc = kern;
  Rng rng(config.goal_library_seed, 1);  // the goal library's seed, its own stream
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const int want = config.goal_library_size;
  std::vector<double> out;
  // Cheap FK and the cup axis first (about 1 in 130 uniform configurations
  // holds the cup within 10 deg), rows and ground truth only for those.
  const int64_t max_batches = 4096 + 20000 * static_cast<int64_t>(want);
  for (int64_t b = 0; b < max_batches && static_cast<int>(out.size()) < want * kArmJoints; ++b) {
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(kc.q_lo[j], kc.q_hi[j]);
    lanes::arm_fk_lanes(kc.fk, ql, fk, false);
    lanes::arm_upright_row_lanes(kc, fk, o, false);
    bool any = false;
    for (int l = 0; l < kLanes; ++l) any = any || cup_upright(o, l);
    if (!any) continue;
    lanes::arm_constraints_lanes(kc, ql, fk, o, false);
    lanes::arm_ground_truth_lanes(kc, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && static_cast<int>(out.size()) < want * kArmJoints; ++l)
      if (!o.collision[l] && !o.joint_violation[l] && pose_ok(o, l))
        for (int j = 0; j < kArmJoints; ++j) out.push_back(ql[j][l]);
  }
  if (out.empty())
    throw std::invalid_argument("hri.start_tilt: no safe configuration holds the cup that close to vertical");
  start_lib_q = std::move(out);
}

void ArmModel::build_spec() {
  EnvSpec& s = spec;
  s.name = arm_task_name(config.task) + (rows.has(ArmRowKind::Upright) ? "-upright" : "");
  s.obs_dim = obs_dim;
  s.act_dim = kArmJoints;
  s.dt = config.dt;
  s.horizon = config.horizon;
  s.gamma = 0.995;  // the task's discount (reference 5.3)
  s.num_constraints = k;
  for (int j = 0; j < kArmJoints; ++j) {
    s.obs_low.push_back(static_cast<float>(robot.lower[j]));
    s.obs_high.push_back(static_cast<float>(robot.upper[j]));
  }
  for (int r = 0; r < 3; ++r) {
    s.obs_low.push_back(static_cast<float>(scene.goal_region.min(r)));
    s.obs_high.push_back(static_cast<float>(scene.goal_region.max(r)));
  }
  for (int r = 0; r < 3; ++r) {  // the grasping frame stays within reach of the shoulder
    s.obs_low.push_back(static_cast<float>(robot.shoulder(r) - robot.reach));
    s.obs_high.push_back(static_cast<float>(robot.shoulder(r) + robot.reach));
  }
  for (int r = 0; r < 3; ++r) {
    s.obs_low.push_back(-1.0f);
    s.obs_high.push_back(1.0f);
  }
  if (hri()) {
    for (int r = 0; r < 3; ++r) {  // cup axis
      s.obs_low.push_back(-1.0f);
      s.obs_high.push_back(1.0f);
    }
    // Human capsule midpoints (the motion library spans x 0.56..1.62, y
    // -0.97..0.67 with the body within ~0.6 m of the root) and their
    // velocities (end points below 3.5 m/s in data time).
    const float lo[3] = {-0.5f, -1.8f, 0.0f}, hi[3] = {2.5f, 1.5f, 2.0f};
    for (int c = 0; c < kHumanCapsules; ++c)
      for (int r = 0; r < 3; ++r) {
        s.obs_low.push_back(lo[r]);
        s.obs_high.push_back(hi[r]);
      }
    const float vm = static_cast<float>(3.5 * config.hri.frames_per_step * motion->fps() * config.dt);
    for (int c = 0; c < kHumanCapsules * 3; ++c) {
      s.obs_low.push_back(-vm);
      s.obs_high.push_back(vm);
    }
  }
  for (int j = 0; j < kArmJoints; ++j) {
    s.constraint_names.push_back(robot.joint_names[j] + "_lower");
    s.constraint_tolerance.push_back(config.joint.tolerance[j]);
  }
  for (int j = 0; j < kArmJoints; ++j) {
    s.constraint_names.push_back(robot.joint_names[j] + "_upper");
    s.constraint_tolerance.push_back(config.joint.tolerance[kArmJoints + j]);
  }
  for (int i = 0; i < kArmPoi; ++i) {
    s.constraint_names.push_back("obstacle_" + robot.poi[i].name);
    s.constraint_tolerance.push_back(config.obstacle.tolerance[i]);
  }
  for (int i = 0; i < kArmPoi; ++i) {
    s.constraint_names.push_back("body_" + robot.poi[i].name);
    s.constraint_tolerance.push_back(config.body.tolerance[i]);
  }
  for (int r = 0; r < 2; ++r) {
    s.constraint_names.push_back("ground_" + robot.poi[config.ground_poi[r]].name);
    s.constraint_tolerance.push_back(config.ground.tolerance[r]);
  }
  if (hri()) {
    for (int i = 0; i < kArmPoi; ++i) {
      s.constraint_names.push_back("human_" + robot.poi[i].name);
      s.constraint_tolerance.push_back(config.hri.human.tolerance[size_t(i)]);
    }
    if (rows.has(ArmRowKind::Upright)) {
      s.constraint_names.push_back("cup_upright");
      s.constraint_tolerance.push_back(config.hri.upright.tolerance[0]);
    }
  }
  s.cost_events = {"collision", "joint_limit_violation"};  // HRI's human contact is a collision too
  if (hri() && config.hri.spill_cost) s.cost_events.push_back("spill");
  s.info_names = {"collision", "joint_limit_violation", "final_distance", "distance",
                  "angle",     "in_region",             "nan_action",     "reset_fallback"};
  s.info_reduce = {InfoReduce::Sum,  InfoReduce::Sum,  InfoReduce::Last, InfoReduce::Mean,
                   InfoReduce::Mean, InfoReduce::Mean, InfoReduce::Sum,  InfoReduce::Sum};
  s.info_role = {InfoRole::AnyContact, InfoRole::Diagnostic, InfoRole::GoalDistance, InfoRole::Diagnostic,
                 InfoRole::Diagnostic, InfoRole::Diagnostic, InfoRole::Diagnostic,   InfoRole::Diagnostic};
  if (hri()) {
    // human_collision: steps in contact with the human (an episode ends there);
    // spill, spill_<deg>: 1 for an episode with a spill at either angle;
    // min_human_distance: per episode.
    s.info_names.insert(s.info_names.end(), {"human_collision", "spill", "min_human_distance", "tilt",
                                             config.hri.strict_spill_name()});
    s.info_reduce.insert(s.info_reduce.end(),
                         {InfoReduce::Sum, InfoReduce::Sum, InfoReduce::Last, InfoReduce::Mean, InfoReduce::Sum});
    s.info_role.insert(s.info_role.end(), {InfoRole::Contact, InfoRole::EpisodeEvent, InfoRole::Diagnostic,
                                           InfoRole::Diagnostic, InfoRole::EpisodeEvent});
  }
  s.target = config.target;
  check_env_target(s);
}

const HumanModel& arm_shared_human_model() { return human_data().model; }
const HumanMotionLibrary& arm_shared_human_motion() { return human_data().motion; }

std::shared_ptr<const ArmModel> make_arm_model(const ArmEnvConfig& config) {
  return std::make_shared<const ArmModel>(config);
}

ProjectorModel arm_projector_model(const ArmModel& m) {
  const ArmEnvConfig& c = m.config;
  // Moving groups: the uncontrollable state is their obstacle's clock (p = 1 each).
  ProjectorModel pm = default_projector_model(kArmJoints, kArmJoints, m.k, m.rows.moving_groups());
  for (const ArmRowSpan& g : m.rows.groups) {
    const ArmRowGroup* cfg = nullptr;
    switch (g.kind) {
      case ArmRowKind::Joint: cfg = &c.joint; break;
      case ArmRowKind::Scene: cfg = &c.obstacle; break;
      case ArmRowKind::Body: cfg = &c.body; break;
      case ArmRowKind::Ground: cfg = &c.ground; break;
      case ArmRowKind::Human: cfg = &c.hri.human; break;
      case ArmRowKind::Upright: cfg = &c.hri.upright; break;
    }
    for (int r = 0; r < g.count; ++r) {
      pm.slack[g.begin + r] = SlackType::SoftCorner;
      pm.beta[g.begin + r] = cfg->beta[r];
      pm.tol[g.begin + r] = cfg->slack_tol;
    }
  }
  pm.K_c = 1.0 / c.dt;
  pm.basis = BasisType::Projected;
  pm.g_form = GForm::Diagonal;
  pm.has_drift = false;
  // Static scenes take the default correction-first bounds; with the moving
  // human the per-component clip retreats faster (one row dominates), as on
  // nav. Measured with random actions, 1e7 steps, seed 777001 (issue 31,
  // docs/results.md): 4 human collisions with the clip, 12 with scaling.
  if (m.rows.moving_groups() > 0) pm.bounds = BoundRule::TangentScale;
  pm.validate();
  return pm;
}

}  // namespace atacom
