// The manipulation envs' lifecycle: construction (model, scene, row groups,
// goal library), resets with their initial-state and goal sampling, and the
// batched step. Spec, projector model, scalar reference and snapshots live in
// envs/arm/arm_env_model.cpp; the config in envs/arm/arm_env_config.cpp.
#include "envs/arm/arm_env.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "atacom/parallel.hpp"
#include "envs/arm/arm_env_internal.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "kernels/arm_env_kernel.hpp"

namespace atacom {

using namespace arm_env_detail;
using lanes::kLanes;
using lanes::vd;

namespace {
int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// The human's data, loaded once per process and shared by every HRI env.
struct HumanData {
  HumanModel model = load_human_model();
  HumanMotionLibrary motion = load_default_human_motion();
};
const HumanData& human_data() {
  static const HumanData d;
  return d;
}

// Every lane of h holds env e's human.
void splat_caps(const HumanBatch& B, int e, lanes::HumanCapsLanes& h) {
  const double* cap = &B.cap[static_cast<size_t>(e) * kHumanCapsules * 6];
  const double* vel = &B.cap_vel[static_cast<size_t>(e) * kHumanCapsules * 6];
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      h.a[c][r] = lanes::splat(cap[c * 6 + r]);
      h.b[c][r] = lanes::splat(cap[c * 6 + 3 + r]);
      h.va[c][r] = lanes::splat(vel[c * 6 + r]);
      h.vb[c][r] = lanes::splat(vel[c * 6 + 3 + r]);
    }
  h.pose = &B.pose[static_cast<size_t>(e) * kHumanPoseDim];
  h.pose_rate = &B.pose_rate[static_cast<size_t>(e) * kHumanPoseDim];
  h.count = 1;
}
}  // namespace

// Every row but the human's (those depend on where the human is) within init_margin.
bool ArmEnv::static_rows_ok(const lanes::ArmKernelOut& o, int l) const {
  bool ok = true;
  for (int r = 0; r < kArmRows; ++r) ok = ok && o.c[r][l] <= -config_.init_margin;
  if (hri()) ok = ok && o.c[kRowUpright][l] <= -config_.init_margin;
  return ok;
}

const HumanModel& ArmEnv::human_model() const { return human_data().model; }
const HumanMotionLibrary& ArmEnv::human_motion() const { return human_data().motion; }


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
  kern->learned_body = load_arm_learned_body(config_.sdf, config_.torso_lift);
  k.learned_body = kern->learned_body.get();
  for (int i = 0; i < kArmPoi; ++i) {
    k.delta_obstacle[i] = model_.scene_cover[i] + config_.obstacle.margin[i] + (kern->learned ? kern->learned->margin : 0.0);
    k.delta_body[i] = model_.body_cover[i] + config_.body.margin[i] + (kern->learned_body ? kern->learned_body->margin : 0.0);
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
  rows_ = ArmRowLayout::compose(hri());
  k_ = rows_.k;
  dyn_ = rows_.dynamic_rows();
  obs_dim_ = hri() ? kHriObsDim : kArmObsDim;
  info_count_ = hri() ? kInfoCountHri : kInfoCount;
  if (hri()) {
    const ArmHriConfig& h = config_.hri;
    config_.hri.cup_axis.normalize();
    std::vector<double> delta(kArmPoi);
    kern->learned_human = load_arm_learned_human(config_.sdf);
    k.learned_human = kern->learned_human.get();
    const double learned_margin = kern->learned_human ? kern->learned_human->margin : 0.0;
    for (int i = 0; i < kArmPoi; ++i) {
      delta[size_t(i)] = model_.scene_cover[i] + h.human.margin[size_t(i)] + learned_margin;
      row_offset_hri_[size_t(i)] = delta[size_t(i)];
    }
    human_rows_ = make_human_rows(delta, kArmJoints, h.human_blend);
    k.hri = true;
    k.human = human_rows_;
    k.human_fk = &human_data().model.fk;
    for (int r = 0; r < 3; ++r) k.cup_axis[r] = config_.hri.cup_axis(r);
    k.cos_upright = std::cos(h.theta_max - h.upright.margin[0]);
    row_offset_hri_[kArmPoi] = k.cos_upright;
    replay_.frames_per_step = h.frames_per_step;
    replay_.split = h.split;
    for (const lanes::ArmGtItem& it : k.items) robot_radii_.push_back(it.radius);
  }
  kernel_ = kern;

  // The fallback start must be safe against the static rows (HRI: the human
  // moves, so it is checked per reset), or resets could start inside the constraints.
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
  c_.assign(N * size_t(k_), 0.0);
  J_.assign(((N + kLanes - 1) / kLanes) * kLanes * size_t(dyn_) * kArmJoints, 0.0);
  grasp_.assign(N * 3, 0.0);
  approach_.assign(N * 3, 0.0);
  if (hri()) {
    humans_.resize(num_envs);
    human_t_.assign(N, 0.0);
    dcdt_.assign(N * kArmPoi, 0.0);
    cup_.assign(N * 3, 0.0);
    min_hd_.assign(N, INFINITY);
    spilled_.assign(N, 0);
    items_.assign(N * kernel_->k.items.size() * 6, 0.0);
    contact_.assign(N, 0);
    hd_.assign(N, 0.0);
    final_cap_.assign(N * kHumanCapsules * 6, 0.0);
  }
  buffers_.resize(spec_, num_envs);
  seed(0);
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
    for (int r = 0; r < k_; ++r)
      if (!(o.c[r][l] <= need)) return false;
    return true;
  };
  // HRI: the episode's human first (start frame from this env's stream), so
  // the initial state is drawn clear of it.
  lanes::HumanCapsLanes h;
  if (hri()) {
    human_t_[se] = human_episode_start(human_motion(), replay_, config_.horizon, rng);
    human_at(e, 1);
    splat_caps(humans_, e, h);
    min_hd_[se] = INFINITY;
    spilled_[se] = 0;
  }
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
    if (hri()) lanes::arm_hri_rows_lanes(k, fk, h, o, true);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && !found; ++l)
      if (lane_ok(l)) {
        for (int j = 0; j < kArmJoints; ++j) q_[se * kArmJoints + j] = ql[j][l];
        store_lane(fk, o, l, e, true);
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
  write_obs(e, &buffers_.obs[se * obs_dim_]);
}

bool ArmEnv::in_goal_region(const Eigen::Vector3d& g) const {
  if (!hri()) return scene_.goal_region.contains(g);
  for (const AlignedBox& b : config_.hri.targets)
    if (b.contains(g)) return true;
  return false;
}

void ArmEnv::human_at(int e0, int count) {
  human_motion_range(human_motion(), replay_, config_.dt, human_t_.data(), humans_, e0, e0 + count);
  human_capsules_range(human_model().fk, humans_, e0, e0 + count);
}

void ArmEnv::set_human_time(int i, double t) {
  human_t_[static_cast<size_t>(i)] = t;
  human_at(i, 1);
  refresh(i);
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
  // HRI: one of the target boxes, uniformly (reference 4.4), then library
  // configurations that put the grasp in it.
  const AlignedBox* box = nullptr;
  if (hri()) box = &config_.hri.targets[rng.below(config_.hri.targets.size())];
  auto in_box = [&](const Eigen::Vector3d& g) { return box ? box->contains(g) : in_goal_region(g); };
  int base = 0;
  for (int b = 0; b < config_.sample_batches; ++b) {
    base = static_cast<int>(rng.below(static_cast<uint64_t>(L)));
    if (box) {  // a library entry inside the chosen box (the library covers every box)
      for (int tries = 0; tries < 64 && !box->contains(goal_lib_p_[size_t(base)]); ++tries)
        base = static_cast<int>(rng.below(static_cast<uint64_t>(L)));
    }
    const double* qb = &goal_lib_q_[static_cast<size_t>(base) * kArmJoints];
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j)
        ql[j][l] = std::clamp(qb[j] + config_.goal_jitter * rng.uniform(-1.0, 1.0), k.q_lo[j], k.q_hi[j]);
    lanes::arm_fk_lanes(k.fk, ql, fk, false);
    lanes::arm_constraints_lanes(k, ql, fk, o, false);
    if (hri()) lanes::arm_upright_row_lanes(k, fk, o, false);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes; ++l) {
      const Eigen::Vector3d g(fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]);
      if (!in_box(g) || (g - start).norm() < config_.goal_min_distance) continue;
      if (o.collision[l] || o.joint_violation[l]) continue;
      if (!static_rows_ok(o, l)) continue;  // the goal is a place: the human's rows do not apply
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
  goal_lib_p_.clear();
  // Candidates are uniform in the joint box; cheap FK first, constraints and
  // ground truth only for candidates whose grasping frame is in the region.
  const int64_t max_batches = 4096 + 2000 * static_cast<int64_t>(want);
  for (int64_t b = 0; b < max_batches && static_cast<int>(goal_lib_q_.size()) < want * kArmJoints; ++b) {
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(k.q_lo[j], k.q_hi[j]);
    lanes::arm_fk_lanes(k.fk, ql, fk, false);
    bool in[kLanes], any_in = false;
    for (int l = 0; l < kLanes; ++l) {
      in[l] = in_goal_region({fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]});
      any_in = any_in || in[l];
    }
    if (!any_in) continue;
    lanes::arm_constraints_lanes(k, ql, fk, o, false);
    if (hri()) lanes::arm_upright_row_lanes(k, fk, o, false);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && static_cast<int>(goal_lib_q_.size()) < want * kArmJoints; ++l) {
      if (!in[l] || o.collision[l] || o.joint_violation[l]) continue;
      if (static_rows_ok(o, l)) {
        for (int j = 0; j < kArmJoints; ++j) goal_lib_q_.push_back(ql[j][l]);
        goal_lib_p_.emplace_back(double(fk.grasp_p[0][l]), double(fk.grasp_p[1][l]), double(fk.grasp_p[2][l]));
      }
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
      const size_t d = size_t(obs_dim_), kk = size_t(k_);
      std::memcpy(&buffers_.final_obs[se * d], &buffers_.obs[se * d], sizeof(float) * d);
      std::memcpy(&buffers_.constraints[se * kk], &c_[se * kk], sizeof(double) * kk);
      buffers_.reward[e] = 0.0f;
      buffers_.cost[e] = 0.0f;
      buffers_.terminated[e] = buffers_.truncated[e] = 0;
      const size_t ni = size_t(info_count_);
      for (size_t c = 0; c < ni; ++c) buffers_.info[se * ni + c] = 0.0f;
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
  // HRI: the humans advance on their own clock.
  lanes::HumanCapsLanes h;
  int64_t human_pre_ns = 0, human_ns = 0;  // inside the "rest" and the "distances" windows
  if (hri()) {
    const int64_t th = prof ? now_ns() : 0;
    for (int l = 0; l < cnt; ++l) human_t_[size_t(e0 + l)] += replay_.frames_per_step;
    human_at(e0, cnt);
    constexpr int stride = kHumanCapsules * 6;
    lanes::human_load_caps_lanes(&humans_.cap[size_t(e0) * stride], &humans_.cap_vel[size_t(e0) * stride], cnt, h);
    h.pose = &humans_.pose[size_t(e0) * kHumanPoseDim], h.pose_rate = &humans_.pose_rate[size_t(e0) * kHumanPoseDim], h.count = cnt;
    if (prof) human_pre_ns = now_ns() - th;
  }
  // 2. Kinematics, constraints and ground truth of the reached state.
  const int64_t t1 = prof ? now_ns() : 0;
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  const int64_t t2 = prof ? now_ns() : 0;
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  if (hri()) {
    const int64_t th = prof ? now_ns() : 0;
    lanes::arm_hri_rows_lanes(k, fk, h, o, true);
    const int64_t tg = prof ? now_ns() : 0;
    const size_t n_items = k.items.size();
    lanes::arm_ground_truth_lanes(k, ql, fk, o, cnt, &items_[size_t(e0) * n_items * 6]);
    const int64_t tc = prof ? now_ns() : 0;
    human_contact_range(humans_, *k.human_fk, items_.data(), robot_radii_.data(), static_cast<int>(n_items),
                        contact_.data(), hd_.data(), e0, e0 + cnt);
    if (prof) human_ns += (tg - th) + (now_ns() - tc);
  } else {
    lanes::arm_ground_truth_lanes(k, ql, fk, o, cnt);
  }
  const int64_t t3 = prof ? now_ns() : 0;
  // 3. Reward, termination, observation, autoreset.
  EnvBuffers& B = buffers_;
  const ArmRewardConfig& rw = config_.reward;
  // Jacobians of the whole lane group in one go (e0 is a multiple of kLanes;
  // lanes past N are padding). Resets below overwrite their own lane.
  {
    double* Jg = &J_[static_cast<size_t>(e0) * size_t(dyn_) * kArmJoints];
    for (int r = 0; r < dyn_; ++r)
      for (int j = 0; j < kArmJoints; ++j) lanes::store(Jg + (r * kArmJoints + j) * kLanes, o.J[r][j]);
  }
  const size_t kk = size_t(k_), d = size_t(obs_dim_), ni = size_t(info_count_);
  for (int l = 0; l < cnt; ++l) {
    const int ei = e0 + l;
    const size_t e = static_cast<size_t>(ei);
    store_lane(fk, o, l, ei, false);
    const Eigen::Vector3d g(grasp_[e * 3], grasp_[e * 3 + 1], grasp_[e * 3 + 2]);
    const Eigen::Vector3d goal(goal_[e * 3], goal_[e * 3 + 1], goal_[e * 3 + 2]);
    const Eigen::Vector3d ax(approach_[e * 3], approach_[e * 3 + 1], approach_[e * 3 + 2]);
    const double dist = (g - goal).norm();
    const double ang = std::acos(std::clamp(ax.dot(rw.desired_approach), -1.0, 1.0));
    const bool in_region = scene_.indicator_region.contains(g);
    const bool human_hit = hri() && contact_[e] != 0;
    const bool collision = o.collision[l] || human_hit;
    const bool term = collision || o.joint_violation[l];
    ++t_[ei];
    const bool trunc = !term && t_[ei] >= config_.horizon;
    double tilt = 0.0;
    if (hri()) tilt = std::acos(std::clamp(cup_[e * 3 + 2], -1.0, 1.0));
    const double r = term ? rw.terminal
                          : -rw.rho_d * dist - rw.rho_ang * ang - rw.rho_a * anorm[l] + (in_region ? rw.indicator : 0.0) -
                                (hri() ? config_.hri.rho_tilt * tilt : 0.0);
    ret_[ei] += r;
    double cmax = -1e300;
    for (size_t row = 0; row < kk; ++row) cmax = std::max(cmax, c_[e * kk + row]);
    std::memcpy(&B.constraints[e * kk], &c_[e * kk], sizeof(double) * kk);
    B.reward[e] = static_cast<float>(r);
    B.cost[e] = static_cast<float>(std::max(0.0, cmax));
    B.terminated[e] = term;
    B.truncated[e] = trunc;
    float* info = &B.info[e * ni];
    info[kInfoCollision] = collision ? 1.0f : 0.0f;
    info[kInfoJointViolation] = o.joint_violation[l] ? 1.0f : 0.0f;
    info[kInfoFinalDistance] = static_cast<float>(dist);
    info[kInfoDistance] = static_cast<float>(dist);
    info[kInfoAngle] = static_cast<float>(ang);
    info[kInfoInRegion] = in_region ? 1.0f : 0.0f;
    info[kInfoNanAction] = static_cast<float>(nan_count[l]);
    info[kInfoResetFallback] = 0.0f;
    if (hri()) {
      min_hd_[e] = std::min(min_hd_[e], hd_[e]);
      const bool spill = tilt > config_.hri.spill_angle && !spilled_[e];
      spilled_[e] = spilled_[e] || spill;
      info[kInfoHumanCollision] = human_hit ? 1.0f : 0.0f;
      info[kInfoSpill] = spill ? 1.0f : 0.0f;
      info[kInfoMinHumanDistance] = static_cast<float>(min_hd_[e]);
      info[kInfoTilt] = static_cast<float>(tilt);
    }
    float* fobs = &B.final_obs[e * d];
    write_obs(ei, fobs);
    if (term || trunc) {
      B.episode_return[e] = ret_[ei];
      B.episode_length[e] = t_[ei];
      if (hri()) {
        constexpr size_t stride = kHumanCapsules * 6;
        std::copy_n(&humans_.cap[e * stride], stride, &final_cap_[e * stride]);
      }
      reset_env(ei);
      info[kInfoResetFallback] = fallback_[ei];
    } else {
      std::memcpy(&B.obs[e * d], fobs, sizeof(float) * d);
    }
  }
  if (prof) {
    const int64_t t4 = now_ns();
    // HRI: the human's share is taken out of the sections it ran inside.
    prof_ns_[0].fetch_add(t2 - t1, std::memory_order_relaxed);
    prof_ns_[1].fetch_add(t3 - t2 - (hri() ? human_ns : 0), std::memory_order_relaxed);
    prof_ns_[hri() ? 3 : 2].fetch_add((t1 - t0) + (t4 - t3) - human_pre_ns, std::memory_order_relaxed);
    if (hri()) prof_ns_[2].fetch_add(human_ns + human_pre_ns, std::memory_order_relaxed);
  }
}

}  // namespace atacom
