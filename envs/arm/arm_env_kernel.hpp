// Lane-block kernels of the manipulation envs: the constraint rows of
// envs/arm/arm_rows.hpp with their Jacobians, and the ground-truth collision
// check, for kLanes envs. Inputs are lane-major joint positions and the FK of
// envs/arm/arm_fk_lanes.hpp (HRI: and the human's capsules).
#pragma once
#include <vector>

#include "envs/arm/arm_rows.hpp"
#include "envs/arm/tiago_model.hpp"
#include "kernels/sdf.hpp"
#include "envs/arm/arm_fk_lanes.hpp"
#include "kernels/human_rows_lanes.hpp"
#include "kernels/lanes.hpp"
#include "kernels/redsdf_human_lanes.hpp"
#include "kernels/redsdf_lanes.hpp"
#include "kernels/sdf_impl.hpp"

namespace atacom::lanes {

// A ground-truth item: link capsule or PoI sphere (a == b), in its frame.
struct ArmGtItem {
  int frame = 0;
  double a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  double radius = 0.0;
  double half_length = 0.0;  // |b - a| / 2 (broad phase)
  bool body_check = true;
};

struct ArmKernelConst {
  ArmFkConst fk;
  std::vector<Shape> obstacle, body;
  double obstacle_blend = 0.0, body_blend = 0.0;
  Shape obstacle_bounds;                 // box around the obstacle (broad phase)
  double q_lo[kArmJoints], q_hi[kArmJoints];    // constraint bounds (limits -+ margins)
  double q_min[kArmJoints], q_max[kArmJoints];  // URDF limits (ground truth)
  double delta_obstacle[kArmPoi], delta_body[kArmPoi];
  int ground_poi[2];
  double ground_h[2];
  std::vector<ArmGtItem> items;
  const LearnedObstacle* learned_obstacle = nullptr;  // set: the obstacle rows use this field (not `obstacle`)
  const LearnedObstacle* learned_body = nullptr;      // set: the body rows use this field (not `body`)
  // HRI (hri == false: unused)
  bool hri = false;
  HumanRowsConst human{};                // thresholds of the human rows
  const HumanFkConst* human_fk = nullptr;
  const LearnedHuman* learned_human = nullptr;  // set: the human rows use this field (poses in HumanCapsLanes)
  double cup_axis[3] = {0, 0, 1};        // in the grasping frame
  double cos_upright = 0.0;              // cos(theta_max - margin)
  explicit ArmKernelConst(const TiagoArmModel& m) : fk(m) {}
};

struct ArmKernelOut {
  vd c[kArmMaxRows];                       // constraint values (the env's first k)
  vd J[kArmMaxDynamicRows][kArmJoints];    // Jacobians of rows 14..k-1 (when with_grad)
  vd dcdt[kArmPoi];                        // HRI: J_x of the human rows
  vd d_human[kArmPoi];                     // HRI: exact PoI-to-human distances
  vd approach[3];                          // grasping-frame x axis
  vd cup[3];                               // HRI: cup axis in base_footprint
  bool collision[kLanes];                  // ground-truth contact
  bool joint_violation[kLanes];            // outside the URDF limits
};

// The seam for "distance to a static scene object" (envs/arm/arm_rows.hpp):
// signed distance of point p to the static scene and, when g != nullptr, its
// gradient. A learned field replaces this body (and its scalar twin).
static inline vd arm_scene_distance_lanes(const ArmKernelConst& k, const vd* p, vd* g) {
  return sdf_impl::union_of<vd>(k.obstacle.data(), static_cast<int>(k.obstacle.size()), k.obstacle_blend, p, g);
}

// Constraint rows (values, and Jacobians when with_grad) from the FK.
static inline void arm_constraints_lanes(const ArmKernelConst& k, const vd* q, const ArmFkLanes& fk, ArmKernelOut& o,
                                         bool with_grad) {
  for (int j = 0; j < kArmJoints; ++j) {
    o.c[kRowJointLower + j] = k.q_lo[j] - q[j];
    o.c[kRowJointUpper + j] = q[j] - k.q_hi[j];
  }
  const int n_body = static_cast<int>(k.body.size());
  // A learned field runs all PoIs of the lane block as one network batch.
  vd d_learned[kArmPoi], g_learned[kArmPoi][3], d_body_learned[kArmPoi], g_body_learned[kArmPoi][3];
  if (k.learned_obstacle) learned_distance_lanes(*k.learned_obstacle, fk.poi, kArmPoi, d_learned, with_grad ? g_learned : nullptr);
  if (k.learned_body) learned_distance_lanes(*k.learned_body, fk.poi, kArmPoi, d_body_learned, with_grad ? g_body_learned : nullptr);
  for (int i = 0; i < kArmPoi; ++i) {
    vd g[3];
    vd d_obs;
    if (k.learned_obstacle) {
      d_obs = d_learned[i];
      if (with_grad) g[0] = g_learned[i][0], g[1] = g_learned[i][1], g[2] = g_learned[i][2];
    } else {
      d_obs = arm_scene_distance_lanes(k, fk.poi[i], with_grad ? g : nullptr);
    }
    o.c[kRowScene + i] = k.delta_obstacle[i] - d_obs;
    if (with_grad)
      for (int j = 0; j < kArmJoints; ++j)
        o.J[kRowScene - kRowScene + i][j] = -(g[0] * fk.Jp[i][0][j] + g[1] * fk.Jp[i][1][j] + g[2] * fk.Jp[i][2][j]);
    vd d_body;
    if (k.learned_body) {
      d_body = d_body_learned[i];
      if (with_grad) g[0] = g_body_learned[i][0], g[1] = g_body_learned[i][1], g[2] = g_body_learned[i][2];
    } else {
      d_body = sdf_impl::union_of<vd>(k.body.data(), n_body, k.body_blend, fk.poi[i], with_grad ? g : nullptr);
    }
    o.c[kRowBody + i] = k.delta_body[i] - d_body;
    if (with_grad)
      for (int j = 0; j < kArmJoints; ++j)
        o.J[kRowBody - kRowScene + i][j] = -(g[0] * fk.Jp[i][0][j] + g[1] * fk.Jp[i][1][j] + g[2] * fk.Jp[i][2][j]);
  }
  for (int r = 0; r < 2; ++r) {
    const int i = k.ground_poi[r];
    o.c[kRowGround + r] = k.ground_h[r] - fk.poi[i][2];
    if (with_grad)
      for (int j = 0; j < kArmJoints; ++j) o.J[kRowGround - kRowScene + r][j] = -fk.Jp[i][2][j];
  }
  o.approach[0] = fk.grasp_R[0];
  o.approach[1] = fk.grasp_R[3];
  o.approach[2] = fk.grasp_R[6];
}

// HRI rows (k.hri): PoIs vs the human (fused with the arm's FK; capsules of
// kernels/human_fk_lanes.hpp) and the cup-upright row
//   c = cos(theta_max - margin) - u_z,  u = R_grasp cup_axis,
//   dc/dq_j = -(w_j x u)_z = -(w_jx u_y - w_jy u_x),  w_j = z axis of joint j
// (every joint moves the grasping frame).
static inline void arm_upright_row_lanes(const ArmKernelConst& k, const ArmFkLanes& fk, ArmKernelOut& o, bool with_grad) {
  const vd* R = fk.grasp_R;
  for (int r = 0; r < 3; ++r) o.cup[r] = R[r * 3] * k.cup_axis[0] + R[r * 3 + 1] * k.cup_axis[1] + R[r * 3 + 2] * k.cup_axis[2];
  o.c[kRowUpright] = k.cos_upright - o.cup[2];
  if (with_grad)
    for (int j = 0; j < kArmJoints; ++j)
      o.J[kRowUpright - kRowScene][j] = -(fk.R[j][2] * o.cup[1] - fk.R[j][5] * o.cup[0]);
}

static inline void arm_hri_rows_lanes(const ArmKernelConst& k, const ArmFkLanes& fk, const HumanCapsLanes& h,
                                      ArmKernelOut& o, bool with_grad) {
  vd Jh[kArmPoi][kArmJoints];
  if (k.learned_human)  // o.d_human is not formed (nothing reads it; the contact check is exact)
    learned_human_rows_lanes<kArmJoints>(*k.learned_human, k.human, h.pose, h.pose_rate, h.count, fk.poi, fk.Jp,
                                         &o.c[kRowHuman], Jh, o.dcdt);
  else
    human_rows_lanes<kArmJoints>(k.human, *k.human_fk, fk.poi, fk.Jp, h, &o.c[kRowHuman], Jh, o.dcdt, o.d_human);
  if (with_grad)
    for (int i = 0; i < kArmPoi; ++i)
      for (int j = 0; j < kArmJoints; ++j) o.J[kRowHuman - kRowScene + i][j] = Jh[i][j];
  arm_upright_row_lanes(k, fk, o, with_grad);
}

// Ground truth: joints within URDF limits; every item clear of the floor, the
// obstacle and (if body_check) the body. Broad phase on all lanes with exact
// lower bounds (1-Lipschitz distance at the segment midpoint minus half its
// length); exact segment distances only for lanes and shapes that fail it.
// items_out (optional): the items' end points in base_footprint, per lane
// (count x items x 2 x 3), for the human contact check.
static inline void arm_ground_truth_lanes(const ArmKernelConst& k, const vd* q, const ArmFkLanes& fk, ArmKernelOut& o,
                                          int count, double* items_out = nullptr) {
  vm viol = vm{};
  for (int j = 0; j < kArmJoints; ++j) viol |= (q[j] < k.q_min[j]) | (q[j] > k.q_max[j]);
  vm hit = vm{};
  const int n_obs = static_cast<int>(k.obstacle.size()), n_body = static_cast<int>(k.body.size());
  const size_t n_items = k.items.size();
  for (size_t ii = 0; ii < n_items; ++ii) {
    const ArmGtItem& it = k.items[ii];
    vd A[3], B[3], M[3];
    transform_const(fk.R[it.frame], fk.p[it.frame], it.a, A);
    transform_const(fk.R[it.frame], fk.p[it.frame], it.b, B);
    if (items_out)
      for (int l = 0; l < count; ++l)
        for (int r = 0; r < 3; ++r) {
          items_out[(size_t(l) * n_items + ii) * 6 + r] = A[r][l];
          items_out[(size_t(l) * n_items + ii) * 6 + 3 + r] = B[r][l];
        }
    for (int r = 0; r < 3; ++r) M[r] = 0.5 * (A[r] + B[r]);
    hit |= vmin(A[2], B[2]) < it.radius;  // floor at z = 0
    const double reach = it.half_length + it.radius;
    auto narrow = [&](const Shape* shapes, int n, vm cand) {
      for (int l = 0; l < count; ++l) {
        if (!cand[l] || hit[l]) continue;
        const Eigen::Vector3d a(A[0][l], A[1][l], A[2][l]), b(B[0][l], B[1][l], B[2][l]);
        for (int s = 0; s < n; ++s)
          if (!segment_clear(shapes[s], a, b, it.radius)) {
            hit[l] = -1;
            break;
          }
      }
    };
    const vm near_bounds = sdf_impl::box<vd>(k.obstacle_bounds, M, nullptr) < reach;
    if (any(near_bounds)) {
      const vm cand = near_bounds & (sdf_impl::union_of<vd>(k.obstacle.data(), n_obs, 0.0, M, nullptr) < reach);
      if (any(cand)) narrow(k.obstacle.data(), n_obs, cand);
    }
    if (it.body_check) {
      const vm cand = sdf_impl::union_of<vd>(k.body.data(), n_body, 0.0, M, nullptr) < reach;
      if (any(cand)) narrow(k.body.data(), n_body, cand);
    }
  }
  for (int l = 0; l < kLanes; ++l) {
    o.collision[l] = hit[l] != 0;
    o.joint_violation[l] = viol[l] != 0;
  }
}

}  // namespace atacom::lanes
