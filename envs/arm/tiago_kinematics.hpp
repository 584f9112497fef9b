// Forward kinematics of the TIAGo++ right arm, with positional Jacobians of
// the 9 points of interest and the grasping frame's orientation Jacobian.
//
// Two implementations of the same map:
//  - arm_fk_reference: one configuration, plain Eigen 4x4-style products and
//    cross-product Jacobians. Slow and obvious; the tests hold it against the
//    published FK values and finite differences.
//  - arm_fk_batch: structure-of-arrays over N envs, SIMD across envs (lane
//    blocks of 8, envs/arm/arm_fk_lanes.hpp); the envs call the lane kernel
//    directly and never materialise these arrays.
// Jacobian columns: revolute joint j with world axis z_j through o_j moves a
// point p at z_j x (p - o_j); the orientation Jacobian column is z_j.
#pragma once
#include <array>
#include <vector>

#include <Eigen/Core>

#include "envs/arm/tiago_model.hpp"

namespace atacom {

using ArmQ = Eigen::Matrix<double, kArmJoints, 1>;
using ArmJ = Eigen::Matrix<double, 3, kArmJoints>;

struct ArmFkResult {
  std::array<RigidTransform, kArmFrames> frame;  // link frames in base_footprint
  RigidTransform grasp;                          // fingertip grasping frame (envs)
  RigidTransform grasp_pal;                      // PAL gripper_right_grasping_frame
  std::array<Eigen::Vector3d, kArmPoi> poi;      // PoI positions
  std::array<ArmJ, kArmPoi> J_poi;               // d poi / dq
  ArmJ J_grasp_pos;                              // d grasp.p / dq
  ArmJ J_grasp_rot;                              // angular velocity of the grasping frame per qdot
};

ArmFkResult arm_fk_reference(const TiagoArmModel& model, const ArmQ& q);

struct ArmFkBatch {
  int N = 0;
  std::vector<double> grasp_p;      // (N x 3)         grasping-frame position
  std::vector<double> grasp_R;      // (N x 3 x 3)     grasping-frame rotation, row-major
  std::vector<double> poi;          // (N x 9 x 3)     PoI positions
  std::vector<double> J_poi;        // (N x 9 x 3 x 7) PoI positional Jacobians, row-major
  std::vector<double> J_grasp_pos;  // (N x 3 x 7)
  std::vector<double> J_grasp_rot;  // (N x 3 x 7)
  void resize(int N);
};

// FK of envs [begin, end); q is (N x 7). Runs on the calling thread.
void arm_fk_batch(const TiagoArmModel& model, const double* q, ArmFkBatch& out, int begin, int end);

}  // namespace atacom
