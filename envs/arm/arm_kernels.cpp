// The manipulation envs' batched kernels: resets with their initial-state
// and goal sampling, the step, the cached model and the projector's inputs.
#include "envs/arm/arm_kernels.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "envs/arm/arm_env_kernel.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "kernels/lanes.hpp"

namespace atacom {

using lanes::kLanes;
using lanes::vd;

namespace {
int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Lanes of h hold the humans of envs e0 .. e0 + count - 1.
void load_humans(const ArmBatch& b, int e0, int count, lanes::HumanCapsLanes& h) {
  const HumanBatch& H = b.human.body;
  lanes::human_load_caps_lanes(&H.cap[size_t(e0) * kHumanCapStride], &H.cap_vel[size_t(e0) * kHumanCapStride], count, h);
  h.pose = &H.pose[size_t(e0) * kHumanPoseDim];
  h.pose_rate = &H.pose_rate[size_t(e0) * kHumanPoseDim];
  h.count = count;
}

// Every lane of h holds env e's human.
void splat_human(const ArmBatch& b, int e, lanes::HumanCapsLanes& h) {
  const HumanBatch& H = b.human.body;
  const double* cap = &H.cap[size_t(e) * kHumanCapStride];
  const double* vel = &H.cap_vel[size_t(e) * kHumanCapStride];
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      h.a[c][r] = lanes::splat(cap[c * 6 + r]);
      h.b[c][r] = lanes::splat(cap[c * 6 + 3 + r]);
      h.va[c][r] = lanes::splat(vel[c * 6 + r]);
      h.vb[c][r] = lanes::splat(vel[c * 6 + 3 + r]);
    }
  h.pose = &H.pose[size_t(e) * kHumanPoseDim];
  h.pose_rate = &H.pose_rate[size_t(e) * kHumanPoseDim];
  h.count = 1;
}

// Copy lane l of a kernel evaluation into env e's cached model (Jacobians
// into the lane-major cache when with_jacobian).
void store_lane(const ArmModel& m, ArmBatch& b, const lanes::ArmFkLanes& fk, const lanes::ArmKernelOut& o, int l, int e,
                bool with_jacobian) {
  const size_t se = static_cast<size_t>(e);
  double* c = &b.c[se * size_t(m.k)];
  for (int r = 0; r < m.k; ++r) c[r] = o.c[r][l];
  if (with_jacobian) {
    double* J = b.J.data() + (se / kLanes) * kLanes * size_t(m.dyn) * kArmJoints + se % kLanes;
    for (int r = 0; r < m.dyn; ++r)
      for (int j = 0; j < kArmJoints; ++j) J[(r * kArmJoints + j) * kLanes] = o.J[r][j][l];
  }
  for (int r = 0; r < 3; ++r) {
    b.grasp[se * 3 + r] = fk.grasp_p[r][l];
    b.approach[se * 3 + r] = o.approach[r][l];
  }
  if (m.hri()) {
    for (int i = 0; i < kArmPoi; ++i) b.human.Jx[se * kArmPoi + i] = o.dcdt[i][l];
    for (int r = 0; r < 3; ++r) b.cup[se * 3 + r] = o.cup[r][l];
  }
}

void reset_env(const ArmModel& m, ArmBatch& b, int e, float* obs) {
  const lanes::ArmKernelConst& k = m.kern;
  const ArmEnvConfig& cfg = m.config;
  Rng& rng = b.rng[size_t(e)];
  const size_t se = static_cast<size_t>(e);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const double need = -cfg.init_margin;
  auto lane_ok = [&](int l) {
    if (o.collision[l] || o.joint_violation[l]) return false;
    for (int r = 0; r < m.k; ++r)
      if (!(o.c[r][l] <= need)) return false;
    return true;
  };
  // HRI: the episode's human first (start frame from this env's stream), so
  // the initial state is drawn clear of it.
  lanes::HumanCapsLanes h;
  if (m.hri()) {
    b.human.t[se] = human_episode_start(*m.motion, m.replay, cfg.horizon, rng);
    arm_human_at(m, b, e, e + 1);
    splat_human(b, e, h);
    b.min_hd[se] = INFINITY;
    b.spilled[se] = 0;
  }
  // Initial state: first safe candidate in draw order (deterministic per env):
  // uniform in the joint box, or (HRI with upright starts) a start-library
  // configuration jittered per joint, the cup within start_tilt.
  const int S = static_cast<int>(m.start_lib_q.size() / kArmJoints);
  auto draw = [&]() {
    if (S > 0) {
      const double* qb = &m.start_lib_q[static_cast<size_t>(rng.below(static_cast<uint64_t>(S))) * kArmJoints];
      for (int l = 0; l < kLanes; ++l)
        for (int j = 0; j < kArmJoints; ++j)
          ql[j][l] = std::clamp(qb[j] + cfg.goal_jitter * rng.uniform(-1.0, 1.0), k.q_lo[j], k.q_hi[j]);
      return;
    }
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j) ql[j][l] = rng.uniform(k.q_lo[j], k.q_hi[j]);
  };
  bool found = false;
  for (int s = 0; s < cfg.sample_batches && !found; ++s) {
    draw();
    lanes::arm_fk_lanes(k.fk, ql, fk, true);
    lanes::arm_constraints_lanes(k, ql, fk, o, true);
    if (m.hri()) lanes::arm_hri_rows_lanes(k, fk, h, o, true);
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes && !found; ++l)
      if (lane_ok(l) && m.cup_upright(o, l)) {
        for (int j = 0; j < kArmJoints; ++j) b.q[se * kArmJoints + j] = ql[j][l];
        store_lane(m, b, fk, o, l, e, true);
        found = true;
      }
  }
  uint8_t fb = 0;
  if (!found) {
    std::copy(cfg.home.begin(), cfg.home.end(), &b.q[se * kArmJoints]);
    arm_refresh(m, b, e, nullptr);
    fb = 1;
  }
  const Eigen::Vector3d start(b.grasp[se * 3], b.grasp[se * 3 + 1], b.grasp[se * 3 + 2]);
  if (!arm_sample_goal(m, b, e, start.data(), &b.goal[se * 3])) fb = 1;
  b.fallback[se] = fb;
  b.t[se] = 0;
  b.ret[se] = 0.0;
  arm_write_obs(m, b, e, obs);
}

// Envs e0 .. e0 + cnt - 1, all within one lane group.
void step_group(const ArmModel& m, ArmBatch& b, EnvBuffers& B, const double* actions, int e0, int cnt,
                ArmProfile* prof) {
  const lanes::ArmKernelConst& k = m.kern;
  const ArmEnvConfig& cfg = m.config;
  const bool hri = m.hri();
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
      b.q[e * kArmJoints + j] += cfg.dt * m.vmax[j] * a;
    }
    anorm[l] = std::sqrt(s2);
  }
  for (int j = 0; j < kArmJoints; ++j)
    ql[j] = lanes::load_strided(&b.q[static_cast<size_t>(e0) * kArmJoints + j], kArmJoints, cnt);
  // The moving obstacles advance on their own clock.
  lanes::HumanCapsLanes h;
  int64_t human_pre_ns = 0, human_ns = 0;  // inside the "rest" and the "distances" windows
  if (hri) {
    const int64_t th = prof ? now_ns() : 0;
    for (int l = 0; l < cnt; ++l) b.human.t[size_t(e0 + l)] += m.replay.frames_per_step;
    arm_human_at(m, b, e0, e0 + cnt);
    load_humans(b, e0, cnt, h);
    if (prof) human_pre_ns = now_ns() - th;
  }
  // 2. Kinematics, constraints and ground truth of the reached state.
  const int64_t t1 = prof ? now_ns() : 0;
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  const int64_t t2 = prof ? now_ns() : 0;
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  if (hri) {
    const int64_t th = prof ? now_ns() : 0;
    lanes::arm_hri_rows_lanes(k, fk, h, o, true);
    const int64_t tg = prof ? now_ns() : 0;
    const size_t n_items = k.items.size();
    lanes::arm_ground_truth_lanes(k, ql, fk, o, cnt, &b.items[size_t(e0) * n_items * 6]);
    const int64_t tc = prof ? now_ns() : 0;
    human_contact_range(b.human.body, *k.human_fk, b.items.data(), m.robot_radii.data(), static_cast<int>(n_items),
                        b.contact.data(), b.hd.data(), e0, e0 + cnt);
    if (prof) human_ns += (tg - th) + (now_ns() - tc);
  } else {
    lanes::arm_ground_truth_lanes(k, ql, fk, o, cnt);
  }
  const int64_t t3 = prof ? now_ns() : 0;
  // 3. Reward, termination, observation, autoreset.
  const ArmRewardConfig& rw = cfg.reward;
  // Jacobians of a whole lane group in one go (lanes past N are padding); a
  // group the range cuts stores lane by lane. Resets below overwrite their own lane.
  const bool whole = e0 % kLanes == 0 && (cnt == kLanes || e0 + cnt >= b.N);
  if (whole) {
    double* Jg = &b.J[static_cast<size_t>(e0) * size_t(m.dyn) * kArmJoints];
    for (int r = 0; r < m.dyn; ++r)
      for (int j = 0; j < kArmJoints; ++j) lanes::store(Jg + (r * kArmJoints + j) * kLanes, o.J[r][j]);
  }
  const size_t kk = size_t(m.k), d = size_t(m.obs_dim), ni = size_t(m.info_count);
  for (int l = 0; l < cnt; ++l) {
    const int ei = e0 + l;
    const size_t e = static_cast<size_t>(ei);
    store_lane(m, b, fk, o, l, ei, !whole);
    const Eigen::Vector3d g(b.grasp[e * 3], b.grasp[e * 3 + 1], b.grasp[e * 3 + 2]);
    const Eigen::Vector3d goal(b.goal[e * 3], b.goal[e * 3 + 1], b.goal[e * 3 + 2]);
    const Eigen::Vector3d ax(b.approach[e * 3], b.approach[e * 3 + 1], b.approach[e * 3 + 2]);
    const double dist = (g - goal).norm();
    const double ang = std::acos(std::clamp(ax.dot(rw.desired_approach), -1.0, 1.0));
    const bool in_region = m.scene.indicator_region.contains(g);
    const bool human_hit = hri && b.contact[e] != 0;
    const bool collision = o.collision[l] || human_hit;
    const bool term = collision || o.joint_violation[l];
    ++b.t[e];
    const bool trunc = !term && b.t[e] >= cfg.horizon;
    double tilt = 0.0;
    if (hri) tilt = std::acos(std::clamp(b.cup[e * 3 + 2], -1.0, 1.0));
    const double r = term ? rw.terminal
                          : -rw.rho_d * dist - rw.rho_ang * ang - rw.rho_a * anorm[l] + (in_region ? rw.indicator : 0.0) -
                                (hri ? cfg.hri.rho_tilt * tilt : 0.0);
    b.ret[e] += r;
    double cmax = -1e300;
    for (size_t row = 0; row < kk; ++row) cmax = std::max(cmax, b.c[e * kk + row]);
    std::memcpy(&B.constraints[e * kk], &b.c[e * kk], sizeof(double) * kk);
    B.reward[e] = static_cast<float>(r);
    B.cost_continuous[e] = static_cast<float>(std::max(0.0, cmax));
    B.terminated[e] = term;
    B.truncated[e] = trunc;
    bool cost_event = collision || o.joint_violation[l];
    float* info = &B.info[e * ni];
    info[kInfoCollision] = collision ? 1.0f : 0.0f;
    info[kInfoJointViolation] = o.joint_violation[l] ? 1.0f : 0.0f;
    info[kInfoFinalDistance] = static_cast<float>(dist);
    info[kInfoDistance] = static_cast<float>(dist);
    info[kInfoAngle] = static_cast<float>(ang);
    info[kInfoInRegion] = in_region ? 1.0f : 0.0f;
    info[kInfoNanAction] = static_cast<float>(nan_count[l]);
    info[kInfoResetFallback] = 0.0f;
    if (hri) {
      b.min_hd[e] = std::min(b.min_hd[e], b.hd[e]);
      // spilled: bit 0 once the tilt passed spill_angle, bit 1 spill_angle_strict
      // (each counts once per episode, at its first step).
      const bool spill = tilt > cfg.hri.spill_angle && !(b.spilled[e] & 1);
      const bool spill_strict = tilt > cfg.hri.spill_angle_strict && !(b.spilled[e] & 2);
      b.spilled[e] = uint8_t(b.spilled[e] | (spill ? 1 : 0) | (spill_strict ? 2 : 0));
      info[kInfoHumanCollision] = human_hit ? 1.0f : 0.0f;
      info[kInfoSpill] = spill ? 1.0f : 0.0f;
      info[kInfoMinHumanDistance] = static_cast<float>(b.min_hd[e]);
      info[kInfoTilt] = static_cast<float>(tilt);
      info[kInfoSpillStrict] = spill_strict ? 1.0f : 0.0f;
      if (cfg.hri.spill_cost) cost_event = cost_event || spill;
    }
    B.cost[e] = step_cost(&b.c[e * kk], m.spec.constraint_tolerance.data(), m.k, cost_event);
    float* fobs = &B.final_obs[e * d];
    arm_write_obs(m, b, ei, fobs);
    if (term || trunc) {
      B.episode_return[e] = b.ret[e];
      B.episode_length[e] = b.t[e];
      if (hri) std::copy_n(&b.human.body.cap[e * kHumanCapStride], kHumanCapStride, &b.human.final_cap[e * kHumanCapStride]);
      reset_env(m, b, ei, &B.obs[e * d]);
      info[kInfoResetFallback] = b.fallback[e];
    } else {
      std::memcpy(&B.obs[e * d], fobs, sizeof(float) * d);
    }
  }
  if (prof) {
    const int64_t t4 = now_ns();
    // HRI: the human's share is taken out of the sections it ran inside.
    prof->ns[0].fetch_add(t2 - t1, std::memory_order_relaxed);
    prof->ns[1].fetch_add(t3 - t2 - (hri ? human_ns : 0), std::memory_order_relaxed);
    prof->ns[hri ? 3 : 2].fetch_add((t1 - t0) + (t4 - t3) - human_pre_ns, std::memory_order_relaxed);
    if (hri) prof->ns[2].fetch_add(human_ns + human_pre_ns, std::memory_order_relaxed);
  }
}

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
#if defined(__clang__)
  // Clang has no __builtin_shuffle with a mask vector (only the fuzz build,
  // tests/fuzz, uses clang): the same transpose element by element.
  for (int l = 0; l < 8; ++l)
    for (int k = 0; k < 8; ++k) out[l][k] = in[k][l];
#else
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
#endif
}
}  // namespace

void arm_human_at(const ArmModel& m, ArmBatch& b, int begin, int end) {
  human_motion_range(*m.motion, m.replay, m.config.dt, b.human.t.data(), b.human.body, begin, end);
  human_capsules_range(m.human->fk, b.human.body, begin, end);
}

void arm_reset_range(const ArmModel& m, ArmBatch& b, EnvBuffers& B, const uint8_t* mask, int begin, int end) {
  const size_t d = size_t(m.obs_dim), kk = size_t(m.k), ni = size_t(m.info_count);
  for (int e = begin; e < end; ++e) {
    if (mask && !mask[e]) continue;
    const size_t se = static_cast<size_t>(e);
    reset_env(m, b, e, &B.obs[se * d]);
    std::memcpy(&B.final_obs[se * d], &B.obs[se * d], sizeof(float) * d);
    std::memcpy(&B.constraints[se * kk], &b.c[se * kk], sizeof(double) * kk);
    B.reward[se] = 0.0f;
    B.cost[se] = B.cost_continuous[se] = 0.0f;
    B.terminated[se] = B.truncated[se] = 0;
    for (size_t c = 0; c < ni; ++c) B.info[se * ni + c] = 0.0f;
  }
}

void arm_step_range(const ArmModel& m, ArmBatch& b, EnvBuffers& out, const double* actions, int begin, int end,
                    ArmProfile* prof) {
  for (int e0 = begin; e0 < end;) {
    const int cnt = std::min(kLanes - e0 % kLanes, end - e0);
    step_group(m, b, out, actions, e0, cnt, prof);
    e0 += cnt;
  }
}

// Goal: grasping-frame position of a safe configuration inside the goal
// region (so every goal is reachable without touching a constraint): a
// library configuration, jittered so that goals cover the region densely.
bool arm_sample_goal(const ArmModel& m, ArmBatch& b, int e, const double* away_from, double* goal) {
  const lanes::ArmKernelConst& k = m.kern;
  const ArmEnvConfig& cfg = m.config;
  Rng& rng = b.rng[size_t(e)];
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  vd ql[kArmJoints];
  const Eigen::Vector3d start(away_from[0], away_from[1], away_from[2]);
  const int L = static_cast<int>(m.goal_lib_q.size() / kArmJoints);
  // HRI: one of the target boxes, uniformly (reference 4.4), then library
  // configurations that put the grasp in it.
  const AlignedBox* box = nullptr;
  if (m.hri()) box = &cfg.hri.targets[rng.below(cfg.hri.targets.size())];
  auto in_box = [&](const Eigen::Vector3d& g) { return box ? box->contains(g) : m.in_goal_region(g); };
  int base = 0;
  for (int s = 0; s < cfg.sample_batches; ++s) {
    base = static_cast<int>(rng.below(static_cast<uint64_t>(L)));
    if (box) {  // a library entry inside the chosen box (the library covers every box)
      for (int tries = 0; tries < 64 && !box->contains(m.goal_lib_p[size_t(base)]); ++tries)
        base = static_cast<int>(rng.below(static_cast<uint64_t>(L)));
    }
    const double* qb = &m.goal_lib_q[static_cast<size_t>(base) * kArmJoints];
    for (int l = 0; l < kLanes; ++l)
      for (int j = 0; j < kArmJoints; ++j)
        ql[j][l] = std::clamp(qb[j] + cfg.goal_jitter * rng.uniform(-1.0, 1.0), k.q_lo[j], k.q_hi[j]);
    lanes::arm_fk_lanes(k.fk, ql, fk, false);
    lanes::arm_constraints_lanes(k, ql, fk, o, false);
    if (m.hri()) lanes::arm_upright_row_lanes(k, fk, o, false);  // the cup axis (and the upright row when composed)
    lanes::arm_ground_truth_lanes(k, ql, fk, o, kLanes);
    for (int l = 0; l < kLanes; ++l) {
      const Eigen::Vector3d g(fk.grasp_p[0][l], fk.grasp_p[1][l], fk.grasp_p[2][l]);
      if (!in_box(g) || (g - start).norm() < cfg.goal_min_distance) continue;
      if (o.collision[l] || o.joint_violation[l]) continue;
      if (!m.pose_ok(o, l)) continue;  // the goal is a place: the moving groups' rows do not apply
      for (int r = 0; r < 3; ++r) goal[r] = g(r);
      return true;
    }
  }
  // Fallback: the last library configuration itself (safe, inside the region).
  const ArmFkResult r =
      arm_fk_reference(m.robot, Eigen::Map<const ArmQ>(&m.goal_lib_q[static_cast<size_t>(base) * kArmJoints]));
  for (int c = 0; c < 3; ++c) goal[c] = r.grasp.p(c);
  return false;
}

void arm_write_obs(const ArmModel& m, const ArmBatch& b, int e, float* obs) {
  const size_t se = static_cast<size_t>(e);
  for (int j = 0; j < kArmJoints; ++j) obs[j] = static_cast<float>(b.q[se * kArmJoints + j]);
  for (int r = 0; r < 3; ++r) {
    obs[7 + r] = static_cast<float>(b.goal[se * 3 + r]);
    obs[10 + r] = static_cast<float>(b.grasp[se * 3 + r]);
    obs[13 + r] = static_cast<float>(b.approach[se * 3 + r]);
  }
  if (!m.hri()) return;
  for (int r = 0; r < 3; ++r) obs[16 + r] = static_cast<float>(b.cup[se * 3 + r]);
  const double* cap = &b.human.body.cap[se * kHumanCapStride];
  const double* vel = &b.human.body.cap_vel[se * kHumanCapStride];
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      obs[19 + c * 3 + r] = static_cast<float>(0.5 * (cap[c * 6 + r] + cap[c * 6 + 3 + r]));
      obs[19 + 3 * kHumanCapsules + c * 3 + r] = static_cast<float>(0.5 * (vel[c * 6 + r] + vel[c * 6 + 3 + r]));
    }
}

void arm_refresh(const ArmModel& m, ArmBatch& b, int e, float* obs) {
  const lanes::ArmKernelConst& k = m.kern;
  vd ql[kArmJoints];
  for (int j = 0; j < kArmJoints; ++j) ql[j] = lanes::splat(b.q[static_cast<size_t>(e) * kArmJoints + j]);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  if (m.hri()) {
    lanes::HumanCapsLanes h;
    load_humans(b, e, 1, h);
    lanes::arm_hri_rows_lanes(k, fk, h, o, true);
  }
  store_lane(m, b, fk, o, 0, e, true);
  if (obs) arm_write_obs(m, b, e, &obs[static_cast<size_t>(e) * m.obs_dim]);
}

void arm_constraint_model_range(const ArmModel& m, const ArmBatch& b, ProjectorBatch& pb, int begin, int end) {
  constexpr int n = kArmJoints;
  const int K = m.k;
  const int kDyn = m.dyn * n;  // Jacobian entries per env from the lane-major cache (140 table/shelf, 210 HRI)
  for (int e = begin; e < end; ++e) {
    const size_t se = static_cast<size_t>(e);
    std::memcpy(&pb.c[se * K], &b.c[se * K], sizeof(double) * K);
    std::memcpy(&pb.G[se * n], m.vmax.data(), sizeof(double) * n);
    std::memcpy(&pb.Jq[se * K * n], kJointRows.v, sizeof kJointRows.v);
  }
  // Moving groups: J_x = dc/dt of their rows in the group's column, 0 on every
  // other row; xdot = 1 (the obstacle's clock runs with env time;
  // frames_per_step is inside dc/dt). compensate_motion = false: J_x = 0.
  const int p = m.rows.moving_groups();
  if (p > 0)
    for (int e = begin; e < end; ++e) {
      const size_t se = static_cast<size_t>(e);
      double* Jx = &pb.Jx[se * K * p];
      std::fill(Jx, Jx + K * p, 0.0);
      for (const ArmRowSpan& g : m.rows.groups) {
        if (!g.moving) continue;
        const double* src = &b.moving(g).Jx[se * g.count];
        if (m.config.hri.compensate_motion)
          for (int r = 0; r < g.count; ++r) Jx[(g.begin + r) * p + g.state] = src[r];
        pb.xdot[se * p + g.state] = 1.0;
      }
    }
  // Dynamic rows: whole lane groups by 8x8 register transposes, the rest
  // (partial groups at the range ends, the last 4 entries) element by element.
  int e = begin;
  while (e < end) {
    const size_t se = static_cast<size_t>(e);
    const double* Jg = &b.J[(se / kLanes) * kLanes * kDyn];
    if (e % kLanes == 0 && e + kLanes <= end) {
      int c = 0;
      for (; c + kLanes <= kDyn; c += kLanes) {
        vd in[kLanes], out[kLanes];
        for (int r = 0; r < kLanes; ++r) in[r] = lanes::load(Jg + static_cast<size_t>(c + r) * kLanes);
        transpose8(in, out);
        for (int l = 0; l < kLanes; ++l) lanes::store(&pb.Jq[(se + l) * K * n + kRowScene * n + c], out[l]);
      }
      for (; c < kDyn; ++c)
        for (int l = 0; l < kLanes; ++l) pb.Jq[(se + l) * K * n + kRowScene * n + c] = Jg[c * kLanes + l];
      e += kLanes;
    } else {
      const double* Jl = Jg + se % kLanes;
      for (int c = 0; c < kDyn; ++c) pb.Jq[se * K * n + kRowScene * n + c] = Jl[c * kLanes];
      ++e;
    }
  }
}

}  // namespace atacom
