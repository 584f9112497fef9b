// Lane-block forward kinematics of the TIAGo++ right arm (kLanes envs at once).
//
// Per joint: M = R_parent * R_origin, p = p_parent + R_parent * t_origin, then
// the joint rotation Rz(q) mixes M's first two columns. PoI Jacobian column j
// is z_j x (p - o_j). All constants come from the model (ArmFkConst).
#pragma once
#include "envs/arm/tiago_model.hpp"
#include "kernels/lanes.hpp"

namespace atacom::lanes {

struct ArmFkConst {
  double oR[kArmJoints][9];   // joint origin rotations, row-major
  double op[kArmJoints][3];   // joint origin translations
  double gR[9], gp[3];        // gripper_right_link in arm_right_7_link
  double tR[9], tp[3];        // grasping frame in gripper_right_link
  int poi_frame[kArmPoi];     // 0..7
  int poi_cols[kArmPoi];      // number of joints that move the PoI
  double poi_off[kArmPoi][3];

  explicit ArmFkConst(const TiagoArmModel& m) {
    for (int j = 0; j < kArmJoints; ++j)
      for (int r = 0; r < 3; ++r) {
        op[j][r] = m.joint_origin[j].p(r);
        for (int c = 0; c < 3; ++c) oR[j][r * 3 + c] = m.joint_origin[j].R(r, c);
      }
    for (int r = 0; r < 3; ++r) {
      gp[r] = m.gripper_in_link7.p(r);
      tp[r] = m.grasp_in_gripper.p(r);
      for (int c = 0; c < 3; ++c) {
        gR[r * 3 + c] = m.gripper_in_link7.R(r, c);
        tR[r * 3 + c] = m.grasp_in_gripper.R(r, c);
      }
    }
    for (int i = 0; i < kArmPoi; ++i) {
      poi_frame[i] = m.poi[i].frame;
      poi_cols[i] = m.poi[i].frame == kGripperFrame ? kArmJoints : m.poi[i].frame + 1;
      for (int r = 0; r < 3; ++r) poi_off[i][r] = m.poi[i].offset(r);
    }
  }
};

struct ArmFkLanes {
  vd R[kArmFrames][9];                  // frame rotations in base_footprint, row-major
  vd p[kArmFrames][3];                  // frame origins
  vd grasp_R[9], grasp_p[3];            // grasping frame
  vd poi[kArmPoi][3];                   // PoI positions
  vd Jp[kArmPoi][3][kArmJoints];        // PoI Jacobians (columns >= poi_cols are zero)
};

// R_out = A * B (A lanes, B constant), both row-major 3x3.
static inline void mat_mul_const(const vd* A, const double* B, vd* out) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[r * 3 + c] = A[r * 3] * B[c] + A[r * 3 + 1] * B[3 + c] + A[r * 3 + 2] * B[6 + c];
}
// out = p + A * v (A lanes, v constant).
static inline void transform_const(const vd* A, const vd* p, const double* v, vd* out) {
  for (int r = 0; r < 3; ++r) out[r] = p[r] + (A[r * 3] * v[0] + A[r * 3 + 1] * v[1] + A[r * 3 + 2] * v[2]);
}

// Frames, grasping frame and PoI positions; Jacobians only when with_jacobians.
static inline void arm_fk_lanes(const ArmFkConst& k, const vd* q, ArmFkLanes& o, bool with_jacobians = true) {
  for (int j = 0; j < kArmJoints; ++j) {
    vd M[9];
    if (j == 0) {
      for (int e = 0; e < 9; ++e) M[e] = splat(k.oR[0][e]);
      for (int r = 0; r < 3; ++r) o.p[0][r] = splat(k.op[0][r]);
    } else {
      mat_mul_const(o.R[j - 1], k.oR[j], M);
      transform_const(o.R[j - 1], o.p[j - 1], k.op[j], o.p[j]);
    }
    vd s, c;
    vsincos(q[j], s, c);
    for (int r = 0; r < 3; ++r) {
      const vd m0 = M[r * 3], m1 = M[r * 3 + 1];
      o.R[j][r * 3] = m0 * c + m1 * s;
      o.R[j][r * 3 + 1] = m1 * c - m0 * s;
      o.R[j][r * 3 + 2] = M[r * 3 + 2];
    }
  }
  mat_mul_const(o.R[kArmJoints - 1], k.gR, o.R[kGripperFrame]);
  transform_const(o.R[kArmJoints - 1], o.p[kArmJoints - 1], k.gp, o.p[kGripperFrame]);
  mat_mul_const(o.R[kGripperFrame], k.tR, o.grasp_R);
  transform_const(o.R[kGripperFrame], o.p[kGripperFrame], k.tp, o.grasp_p);
  for (int i = 0; i < kArmPoi; ++i) {
    const int f = k.poi_frame[i];
    transform_const(o.R[f], o.p[f], k.poi_off[i], o.poi[i]);
  }
  if (!with_jacobians) return;
  for (int i = 0; i < kArmPoi; ++i) {
    const int cols = k.poi_cols[i];
    for (int j = 0; j < kArmJoints; ++j) {
      if (j >= cols) {
        o.Jp[i][0][j] = o.Jp[i][1][j] = o.Jp[i][2][j] = vd{};
        continue;
      }
      const vd zx = o.R[j][2], zy = o.R[j][5], zz = o.R[j][8];
      const vd dx = o.poi[i][0] - o.p[j][0], dy = o.poi[i][1] - o.p[j][1], dz = o.poi[i][2] - o.p[j][2];
      o.Jp[i][0][j] = zy * dz - zz * dy;
      o.Jp[i][1][j] = zz * dx - zx * dz;
      o.Jp[i][2][j] = zx * dy - zy * dx;
    }
  }
}

}  // namespace atacom::lanes
