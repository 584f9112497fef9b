// Lane-block kernels of the manipulation envs: the 34 constraint rows with
// their Jacobians, and the ground-truth collision check, for kLanes envs.
// Inputs are lane-major joint positions and the FK of kernels/arm_fk_lanes.hpp.
#pragma once
#include <vector>

#include "envs/arm/arm_env.hpp"
#include "src/core/sdf.hpp"
#include "kernels/arm_fk_lanes.hpp"
#include "kernels/lanes.hpp"
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
  explicit ArmKernelConst(const TiagoArmModel& m) : fk(m) {}
};

struct ArmKernelOut {
  vd c[kArmRows];                          // constraint values
  vd J[kArmDynamicRows][kArmJoints];       // Jacobians of rows 14..33 (when with_grad)
  vd approach[3];                          // grasping-frame x axis
  bool collision[kLanes];                  // ground-truth contact
  bool joint_violation[kLanes];            // outside the URDF limits
};

// Constraint rows (values, and Jacobians when with_grad) from the FK.
static inline void arm_constraints_lanes(const ArmKernelConst& k, const vd* q, const ArmFkLanes& fk, ArmKernelOut& o,
                                         bool with_grad) {
  for (int j = 0; j < kArmJoints; ++j) {
    o.c[kRowJointLower + j] = k.q_lo[j] - q[j];
    o.c[kRowJointUpper + j] = q[j] - k.q_hi[j];
  }
  const int n_obs = static_cast<int>(k.obstacle.size()), n_body = static_cast<int>(k.body.size());
  vd d_learned[kArmPoi], g_learned[kArmPoi][3];
  if (k.learned_obstacle) learned_distance_lanes(*k.learned_obstacle, fk.poi, kArmPoi, d_learned, with_grad ? g_learned : nullptr);
  for (int i = 0; i < kArmPoi; ++i) {
    vd g[3];
    vd d_obs;
    if (k.learned_obstacle) {
      d_obs = d_learned[i];
      if (with_grad) g[0] = g_learned[i][0], g[1] = g_learned[i][1], g[2] = g_learned[i][2];
    } else {
      d_obs = sdf_impl::union_of<vd>(k.obstacle.data(), n_obs, k.obstacle_blend, fk.poi[i], with_grad ? g : nullptr);
    }
    o.c[kRowScene + i] = k.delta_obstacle[i] - d_obs;
    if (with_grad)
      for (int j = 0; j < kArmJoints; ++j)
        o.J[kRowScene - kRowScene + i][j] = -(g[0] * fk.Jp[i][0][j] + g[1] * fk.Jp[i][1][j] + g[2] * fk.Jp[i][2][j]);
    const vd d_body = sdf_impl::union_of<vd>(k.body.data(), n_body, k.body_blend, fk.poi[i], with_grad ? g : nullptr);
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

// Ground truth: joints within URDF limits; every item clear of the floor, the
// obstacle and (if body_check) the body. Broad phase on all lanes with exact
// lower bounds (1-Lipschitz distance at the segment midpoint minus half its
// length); exact segment distances only for lanes and shapes that fail it.
static inline void arm_ground_truth_lanes(const ArmKernelConst& k, const vd* q, const ArmFkLanes& fk, ArmKernelOut& o,
                                          int count) {
  vm viol = vm{};
  for (int j = 0; j < kArmJoints; ++j) viol |= (q[j] < k.q_min[j]) | (q[j] > k.q_max[j]);
  vm hit = vm{};
  const int n_obs = static_cast<int>(k.obstacle.size()), n_body = static_cast<int>(k.body.size());
  for (const ArmGtItem& it : k.items) {
    vd A[3], B[3], M[3];
    transform_const(fk.R[it.frame], fk.p[it.frame], it.a, A);
    transform_const(fk.R[it.frame], fk.p[it.frame], it.b, B);
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
