// Scalar per-env reference of the manipulation envs' batched evaluation:
// FK, every row group with its Jacobian, the ground-truth check, in plain
// Eigen on src/core/sdf shapes (no lane code), for tests and tools.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "envs/arm/arm_kernels.hpp"
#include "envs/arm/tiago_kinematics.hpp"

namespace atacom {

double arm_scene_distance_reference(const ArmModel& m, const Eigen::Vector3d& p, Eigen::Vector3d* grad) {
  // The rows' field: the learned one when configured (its double-precision twin), else the exact shapes.
  if (m.learned) return learned_distance_reference(*m.learned, p, grad);
  return union_distance(m.scene.obstacle, p, grad);
}

ArmEval evaluate_reference(const ArmModel& m, const double* q, const HumanFkResult* human) {
  const TiagoArmModel& robot = m.robot;
  const ArmScene& scene = m.scene;
  ArmEval ev;
  const ArmFkResult fk = arm_fk_reference(robot, Eigen::Map<const ArmQ>(q));
  ev.c.setZero(m.k);
  ev.J.setZero(m.k, kArmJoints);
  ev.dcdt.setZero(m.k);
  for (int j = 0; j < kArmJoints; ++j) {
    ev.c(kRowJointLower + j) = m.row_offset[kRowJointLower + j] - q[j];
    ev.J(kRowJointLower + j, j) = -1.0;
    ev.c(kRowJointUpper + j) = q[j] - m.row_offset[kRowJointUpper + j];
    ev.J(kRowJointUpper + j, j) = 1.0;
    ev.joint_violation = ev.joint_violation || q[j] < robot.lower[j] || q[j] > robot.upper[j];
  }
  for (int i = 0; i < kArmPoi; ++i) {
    Eigen::Vector3d g;
    const double d_obs = arm_scene_distance_reference(m, fk.poi[i], &g);
    ev.c(kRowScene + i) = m.row_offset[kRowScene + i] - d_obs;
    ev.J.row(kRowScene + i) = -(g.transpose() * fk.J_poi[i]);
    const double d_body = m.learned_body ? learned_distance_reference(*m.learned_body, fk.poi[i], &g)
                                         : union_distance(scene.body, fk.poi[i], &g);
    ev.c(kRowBody + i) = m.row_offset[kRowBody + i] - d_body;
    ev.J.row(kRowBody + i) = -(g.transpose() * fk.J_poi[i]);
  }
  for (int r = 0; r < 2; ++r) {
    const int i = m.config.ground_poi[r];
    ev.c(kRowGround + r) = m.row_offset[kRowGround + r] - fk.poi[i].z();
    ev.J.row(kRowGround + r) = -fk.J_poi[i].row(2);
  }
  ev.grasp_p = fk.grasp.p;
  ev.approach = fk.grasp.R.col(0);
  // Ground truth: every capsule and PoI sphere against floor, obstacle, body.
  auto check = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius, bool body) {
    if (std::min(a.z(), b.z()) < radius) return true;
    for (const Shape& s : scene.obstacle.shapes)
      if (segment_distance(s, a, b) < radius) return true;
    if (body)
      for (const Shape& s : scene.body.shapes)
        if (segment_distance(s, a, b) < radius) return true;
    return false;
  };
  for (const ArmCapsule& cap : robot.capsules)
    ev.collision = ev.collision ||
                   check(fk.frame[cap.frame].apply(cap.a), fk.frame[cap.frame].apply(cap.b), cap.radius, cap.body_check);
  for (int i = 0; i < kArmPoi; ++i)
    ev.collision = ev.collision || check(fk.poi[i], fk.poi[i], robot.poi[i].radius, robot.poi[i].body_check);
  if (!m.hri()) return ev;
  // Cup axis and (hri-upright) the upright row: u = R cup_axis, c = cos(theta_max - margin) - u_z,
  // dc/dq_j = -(w_j x u)_z with w_j the grasping frame's angular Jacobian.
  ev.cup_axis = fk.grasp.R * m.config.hri.cup_axis;
  ev.tilt = std::acos(std::clamp(ev.cup_axis.z(), -1.0, 1.0));
  if (m.rows.has(ArmRowKind::Upright)) {
    ev.c(kRowUpright) = m.row_offset_hri[kArmPoi] - ev.cup_axis.z();
    for (int j = 0; j < kArmJoints; ++j)
      ev.J(kRowUpright, j) = -Eigen::Vector3d(fk.J_grasp_rot.col(j)).cross(ev.cup_axis).z();
  }
  if (!human) {
    ev.c.segment(kRowHuman, kArmPoi).setConstant(-INFINITY);
    return ev;
  }
  // Human rows and contact (envs/arm/human_rows.hpp references).
  std::vector<Eigen::Vector3d> poi(fk.poi.begin(), fk.poi.end());
  std::vector<Eigen::MatrixXd> J_poi(fk.J_poi.begin(), fk.J_poi.end());
  const HumanRowsReference hr = human_rows_reference(*m.human, m.human_rows, *human, poi, J_poi);
  ev.c.segment(kRowHuman, kArmPoi) = hr.c;
  ev.J.middleRows(kRowHuman, kArmPoi) = hr.Jq;
  ev.dcdt.segment(kRowHuman, kArmPoi) = hr.dcdt;
  std::vector<RobotPart> parts;
  for (const ArmCapsule& cap : robot.capsules)
    parts.push_back({fk.frame[cap.frame].apply(cap.a), fk.frame[cap.frame].apply(cap.b), cap.radius});
  for (int i = 0; i < kArmPoi; ++i)
    if (!robot.poi[i].inside_capsule) parts.push_back({fk.poi[i], fk.poi[i], robot.poi[i].radius});
  ev.human_distance = human_min_distance_reference(*m.human, *human, parts);
  ev.human_collision = ev.human_distance < 0.0;
  ev.collision = ev.collision || ev.human_collision;
  return ev;
}

}  // namespace atacom
