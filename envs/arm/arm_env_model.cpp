// What the manipulation envs expose about their model: the spec, the
// projector model and the per-env constraint model (J_q, and J_x / xdot for
// the moving human), observations, the scalar reference evaluation and
// snapshots.
#include "envs/arm/arm_env.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <istream>
#include <ostream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "envs/arm/arm_env_internal.hpp"
#include "kernels/arm_env_kernel.hpp"

namespace atacom {

using namespace arm_env_detail;
using lanes::kLanes;
using lanes::vd;

void ArmEnv::build_spec() {
  EnvSpec& s = spec_;
  s.name = arm_task_name(config_.task);
  s.obs_dim = obs_dim_;
  s.act_dim = kArmJoints;
  s.dt = config_.dt;
  s.horizon = config_.horizon;
  s.gamma = 0.995;  // the task's discount (reference 5.3)
  s.num_constraints = k_;
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
    const float vmax = static_cast<float>(3.5 * config_.hri.frames_per_step * human_motion().fps() * config_.dt);
    for (int c = 0; c < kHumanCapsules * 3; ++c) {
      s.obs_low.push_back(-vmax);
      s.obs_high.push_back(vmax);
    }
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
  if (hri()) {
    for (int i = 0; i < kArmPoi; ++i) {
      s.constraint_names.push_back("human_" + model_.poi[i].name);
      s.constraint_tolerance.push_back(config_.hri.human.tolerance[size_t(i)]);
    }
    s.constraint_names.push_back("cup_upright");
    s.constraint_tolerance.push_back(config_.hri.upright.tolerance[0]);
  }
  s.info_names = {"collision", "joint_limit_violation", "final_distance", "distance",
                  "angle",     "in_region",             "nan_action",     "reset_fallback"};
  s.info_reduce = {InfoReduce::Sum,  InfoReduce::Sum,  InfoReduce::Last, InfoReduce::Mean,
                   InfoReduce::Mean, InfoReduce::Mean, InfoReduce::Sum,  InfoReduce::Sum};
  if (hri()) {
    // human_collision: steps in contact with the human (an episode ends there);
    // spill: 1 for an episode with a spill; min_human_distance: per episode.
    s.info_names.insert(s.info_names.end(), {"human_collision", "spill", "min_human_distance", "tilt"});
    s.info_reduce.insert(s.info_reduce.end(), {InfoReduce::Sum, InfoReduce::Sum, InfoReduce::Last, InfoReduce::Mean});
  }
}

ProjectorModel ArmEnv::projector_model() const {
  // HRI: the uncontrollable state is the human's motion time (p = 1).
  ProjectorModel pm = default_projector_model(kArmJoints, kArmJoints, k_, hri() ? 1 : 0);
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
  if (hri()) {
    fill(config_.hri.human, kRowHuman, kArmPoi);
    fill(config_.hri.upright, kRowUpright, 1);
  }
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

void ArmEnv::constraint_model(ProjectorBatch& pb, int begin, int end) const {
  constexpr int n = kArmJoints;
  const int K = k_;
  const int kDyn = dyn_ * n;  // Jacobian entries per env from the lane-major cache (140 table/shelf, 210 HRI)
  for (int e = begin; e < end; ++e) {
    const size_t se = static_cast<size_t>(e);
    std::memcpy(&pb.c[se * K], &c_[se * K], sizeof(double) * K);
    std::memcpy(&pb.G[se * n], vmax_.data(), sizeof(double) * n);
    std::memcpy(&pb.Jq[se * K * n], kJointRows.v, sizeof kJointRows.v);
  }
  // The moving human: J_x = dc/dt of its rows, 0 elsewhere; xdot = 1 (its
  // clock runs with env time; frames_per_step is inside dc/dt).
  if (hri())
    for (int e = begin; e < end; ++e) {
      const size_t se = static_cast<size_t>(e);
      double* Jx = &pb.Jx[se * K];
      std::fill(Jx, Jx + K, 0.0);
      if (config_.hri.compensate_motion) std::memcpy(Jx + kRowHuman, &dcdt_[se * kArmPoi], sizeof(double) * kArmPoi);
      pb.xdot[se] = 1.0;
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
        for (int l = 0; l < kLanes; ++l) lanes::store(&pb.Jq[(se + l) * K * n + kRowScene * n + k], out[l]);
      }
      for (; k < kDyn; ++k)
        for (int l = 0; l < kLanes; ++l) pb.Jq[(se + l) * K * n + kRowScene * n + k] = Jg[k * kLanes + l];
      e += kLanes;
    } else {
      const double* Jl = Jg + se % kLanes;
      for (int k = 0; k < kDyn; ++k) pb.Jq[se * K * n + kRowScene * n + k] = Jl[k * kLanes];
      ++e;
    }
  }
}

void ArmEnv::set_profiling(bool on) {
  profiling_ = on;
  for (auto& p : prof_ns_) p.store(0);
}

std::vector<double> ArmEnv::profile_seconds() const {
  std::vector<double> out;
  for (size_t i = 0; i < profile_sections().size(); ++i) out.push_back(prof_ns_[i].load() * 1e-9);
  return out;
}

void ArmEnv::write_obs(int e, float* obs) const {
  const size_t se = static_cast<size_t>(e);
  for (int j = 0; j < kArmJoints; ++j) obs[j] = static_cast<float>(q_[se * kArmJoints + j]);
  for (int r = 0; r < 3; ++r) {
    obs[7 + r] = static_cast<float>(goal_[se * 3 + r]);
    obs[10 + r] = static_cast<float>(grasp_[se * 3 + r]);
    obs[13 + r] = static_cast<float>(approach_[se * 3 + r]);
  }
  if (!hri()) return;
  for (int r = 0; r < 3; ++r) obs[16 + r] = static_cast<float>(cup_[se * 3 + r]);
  const double* cap = &humans_.cap[se * kHumanCapsules * 6];
  const double* vel = &humans_.cap_vel[se * kHumanCapsules * 6];
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      obs[19 + c * 3 + r] = static_cast<float>(0.5 * (cap[c * 6 + r] + cap[c * 6 + 3 + r]));
      obs[19 + 3 * kHumanCapsules + c * 3 + r] = static_cast<float>(0.5 * (vel[c * 6 + r] + vel[c * 6 + 3 + r]));
    }
}

void ArmEnv::store_lane(const lanes::ArmFkLanes& fk, const lanes::ArmKernelOut& o, int l, int e, bool with_jacobian) {
  const size_t se = static_cast<size_t>(e);
  double* c = &c_[se * size_t(k_)];
  for (int r = 0; r < k_; ++r) c[r] = o.c[r][l];
  if (with_jacobian) {
    double* J = J_.data() + (se / kLanes) * kLanes * size_t(dyn_) * kArmJoints + se % kLanes;
    for (int r = 0; r < dyn_; ++r)
      for (int j = 0; j < kArmJoints; ++j) J[(r * kArmJoints + j) * kLanes] = o.J[r][j][l];
  }
  for (int r = 0; r < 3; ++r) {
    grasp_[se * 3 + r] = fk.grasp_p[r][l];
    approach_[se * 3 + r] = o.approach[r][l];
  }
  if (hri()) {
    for (int i = 0; i < kArmPoi; ++i) dcdt_[se * kArmPoi + i] = o.dcdt[i][l];
    for (int r = 0; r < 3; ++r) cup_[se * 3 + r] = o.cup[r][l];
  }
}

void ArmEnv::refresh(int e) {
  const lanes::ArmKernelConst& k = kernel_->k;
  vd ql[kArmJoints];
  for (int j = 0; j < kArmJoints; ++j) ql[j] = lanes::splat(q_[static_cast<size_t>(e) * kArmJoints + j]);
  lanes::ArmFkLanes fk;
  lanes::ArmKernelOut o;
  lanes::arm_fk_lanes(k.fk, ql, fk, true);
  lanes::arm_constraints_lanes(k, ql, fk, o, true);
  if (hri()) {
    lanes::HumanCapsLanes h;
    constexpr int stride = kHumanCapsules * 6;
    lanes::human_load_caps_lanes(&humans_.cap[size_t(e) * stride], &humans_.cap_vel[size_t(e) * stride], 1, h);
    h.pose = &humans_.pose[size_t(e) * kHumanPoseDim], h.pose_rate = &humans_.pose_rate[size_t(e) * kHumanPoseDim], h.count = 1;
    lanes::arm_hri_rows_lanes(k, fk, h, o, true);
  }
  const size_t se = static_cast<size_t>(e);
  store_lane(fk, o, 0, e, true);
  write_obs(e, &buffers_.obs[se * obs_dim_]);
}


ArmEval ArmEnv::evaluate_reference(const double* q, const HumanFkResult* human) const {
  ArmEval ev;
  const ArmFkResult fk = arm_fk_reference(model_, Eigen::Map<const ArmQ>(q));
  ev.c.setZero(k_);
  ev.J.setZero(k_, kArmJoints);
  ev.dcdt.setZero(k_);
  for (int j = 0; j < kArmJoints; ++j) {
    ev.c(kRowJointLower + j) = row_offset_[kRowJointLower + j] - q[j];
    ev.J(kRowJointLower + j, j) = -1.0;
    ev.c(kRowJointUpper + j) = q[j] - row_offset_[kRowJointUpper + j];
    ev.J(kRowJointUpper + j, j) = 1.0;
    ev.joint_violation = ev.joint_violation || q[j] < model_.lower[j] || q[j] > model_.upper[j];
  }
  for (int i = 0; i < kArmPoi; ++i) {
    Eigen::Vector3d g;
    const double d_obs = arm_scene_distance_reference(fk.poi[i], &g);
    ev.c(kRowScene + i) = row_offset_[kRowScene + i] - d_obs;
    ev.J.row(kRowScene + i) = -(g.transpose() * fk.J_poi[i]);
    const double d_body = kernel_->learned_body ? learned_distance_reference(*kernel_->learned_body, fk.poi[i], &g)
                                                : union_distance(scene_.body, fk.poi[i], &g);
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
  if (!hri()) return ev;
  // Cup axis and upright row: u = R cup_axis, c = cos(theta_max - margin) - u_z,
  // dc/dq_j = -(w_j x u)_z with w_j the grasping frame's angular Jacobian.
  ev.cup_axis = fk.grasp.R * config_.hri.cup_axis;
  ev.tilt = std::acos(std::clamp(ev.cup_axis.z(), -1.0, 1.0));
  ev.c(kRowUpright) = row_offset_hri_[kArmPoi] - ev.cup_axis.z();
  for (int j = 0; j < kArmJoints; ++j)
    ev.J(kRowUpright, j) = -Eigen::Vector3d(fk.J_grasp_rot.col(j)).cross(ev.cup_axis).z();
  if (!human) {
    ev.c.segment(kRowHuman, kArmPoi).setConstant(-INFINITY);
    return ev;
  }
  // Human rows and contact (envs/arm/human_rows.hpp references).
  std::vector<Eigen::Vector3d> poi(fk.poi.begin(), fk.poi.end());
  std::vector<Eigen::MatrixXd> J_poi(fk.J_poi.begin(), fk.J_poi.end());
  const HumanRowsReference hr = human_rows_reference(human_model(), human_rows_, *human, poi, J_poi);
  ev.c.segment(kRowHuman, kArmPoi) = hr.c;
  ev.J.middleRows(kRowHuman, kArmPoi) = hr.Jq;
  ev.dcdt.segment(kRowHuman, kArmPoi) = hr.dcdt;
  std::vector<RobotPart> parts;
  for (const ArmCapsule& cap : model_.capsules)
    parts.push_back({fk.frame[cap.frame].apply(cap.a), fk.frame[cap.frame].apply(cap.b), cap.radius});
  for (int i = 0; i < kArmPoi; ++i)
    if (!model_.poi[i].inside_capsule) parts.push_back({fk.poi[i], fk.poi[i], model_.poi[i].radius});
  ev.human_distance = human_min_distance_reference(human_model(), *human, parts);
  ev.human_collision = ev.human_distance < 0.0;
  ev.collision = ev.collision || ev.human_collision;
  return ev;
}

// Scalar twin of lanes::arm_scene_distance_lanes (the learned-field seam).
double ArmEnv::arm_scene_distance_reference(const Eigen::Vector3d& p, Eigen::Vector3d* grad) const {
  return union_distance(scene_.obstacle, p, grad);
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
  write_obs(i, &buffers_.obs[static_cast<size_t>(i) * obs_dim_]);
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
  if (hri()) {
    put(humans_.pose);
    put(humans_.pose_rate);
    put(humans_.cap);
    put(humans_.cap_vel);
    put(human_t_);
    put(dcdt_);
    put(cup_);
    put(min_hd_);
    put(spilled_);
  }
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
  if (hri()) {
    get(humans_.pose);
    get(humans_.pose_rate);
    get(humans_.cap);
    get(humans_.cap_vel);
    get(human_t_);
    get(dcdt_);
    get(cup_);
    get(min_hd_);
    get(spilled_);
  }
  get(buffers_.obs);
  if (!in) throw std::runtime_error("arm env snapshot is truncated");
}

}  // namespace atacom