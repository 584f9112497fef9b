#include "envs/arm/tiago_kinematics.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "envs/arm/arm_fk_lanes.hpp"

namespace atacom {

namespace {
// Moving point p: column j is z_j x (p - o_j) for every joint before frame f.
ArmJ point_jacobian(const ArmFkResult& r, int frame, const Eigen::Vector3d& p) {
  ArmJ J = ArmJ::Zero();
  const int cols = frame == kGripperFrame ? kArmJoints : frame + 1;
  for (int j = 0; j < cols; ++j) J.col(j) = r.frame[j].R.col(2).cross(p - r.frame[j].p);
  return J;
}
}  // namespace

ArmFkResult arm_fk_reference(const TiagoArmModel& m, const ArmQ& q) {
  ArmFkResult r;
  RigidTransform parent;
  for (int j = 0; j < kArmJoints; ++j) {
    RigidTransform rot;
    rot.R = Eigen::AngleAxisd(q(j), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    r.frame[j] = parent * m.joint_origin[j] * rot;
    parent = r.frame[j];
  }
  r.frame[kGripperFrame] = r.frame[kArmJoints - 1] * m.gripper_in_link7;
  r.grasp = r.frame[kGripperFrame] * m.grasp_in_gripper;
  r.grasp_pal = r.frame[kGripperFrame] * m.grasp_pal_in_gripper;
  for (int i = 0; i < kArmPoi; ++i) {
    r.poi[i] = r.frame[m.poi[i].frame].apply(m.poi[i].offset);
    r.J_poi[i] = point_jacobian(r, m.poi[i].frame, r.poi[i]);
  }
  r.J_grasp_pos = point_jacobian(r, kGripperFrame, r.grasp.p);
  for (int j = 0; j < kArmJoints; ++j) r.J_grasp_rot.col(j) = r.frame[j].R.col(2);
  return r;
}

void ArmFkBatch::resize(int n) {
  N = n;
  const size_t sN = static_cast<size_t>(n);
  grasp_p.assign(sN * 3, 0.0);
  grasp_R.assign(sN * 9, 0.0);
  poi.assign(sN * kArmPoi * 3, 0.0);
  J_poi.assign(sN * kArmPoi * 3 * kArmJoints, 0.0);
  J_grasp_pos.assign(sN * 3 * kArmJoints, 0.0);
  J_grasp_rot.assign(sN * 3 * kArmJoints, 0.0);
}

void arm_fk_batch(const TiagoArmModel& model, const double* q, ArmFkBatch& out, int begin, int end) {
  using namespace lanes;
  const ArmFkConst k(model);
  // The grasping frame moves like a PoI on the gripper frame.
  ArmFkConst kg = k;
  kg.poi_frame[0] = kGripperFrame;
  kg.poi_cols[0] = kArmJoints;
  for (int r = 0; r < 3; ++r) kg.poi_off[0][r] = model.grasp_in_gripper.p(r);
  ArmFkLanes L, Lg;
  for (int e0 = begin; e0 < end; e0 += kLanes) {
    const int cnt = end - e0 < kLanes ? end - e0 : kLanes;
    vd ql[kArmJoints];
    for (int j = 0; j < kArmJoints; ++j) ql[j] = load_strided(q + static_cast<size_t>(e0) * kArmJoints + j, kArmJoints, cnt);
    arm_fk_lanes(k, ql, L);
    arm_fk_lanes(kg, ql, Lg);
    for (int l = 0; l < cnt; ++l) {
      const size_t e = static_cast<size_t>(e0 + l);
      for (int r = 0; r < 3; ++r) {
        out.grasp_p[e * 3 + r] = L.grasp_p[r][l];
        for (int c = 0; c < 3; ++c) out.grasp_R[e * 9 + r * 3 + c] = L.grasp_R[r * 3 + c][l];
        for (int j = 0; j < kArmJoints; ++j) {
          out.J_grasp_pos[(e * 3 + r) * kArmJoints + j] = Lg.Jp[0][r][j][l];
          out.J_grasp_rot[(e * 3 + r) * kArmJoints + j] = L.R[j][r * 3 + 2][l];
        }
      }
      for (int i = 0; i < kArmPoi; ++i)
        for (int r = 0; r < 3; ++r) {
          out.poi[(e * kArmPoi + i) * 3 + r] = L.poi[i][r][l];
          for (int j = 0; j < kArmJoints; ++j)
            out.J_poi[((e * kArmPoi + i) * 3 + r) * kArmJoints + j] = L.Jp[i][r][j][l];
        }
    }
  }
}

}  // namespace atacom
