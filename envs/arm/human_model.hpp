// The capsule human: a 1.75 m adult as 16 capsules on a 20-joint chain
// (data/human_skeleton.json: Winter's segment lengths, ANSUR II radii) with 34
// joint angles (data/human_dofs.json: axes, order, limits; ours) and a root
// pose on the floor. Static, built once, shared by every env and thread.
//
// Pose layout and the batched kernels: kernels/human_kernels.hpp. This file
// holds the model (names, limits, the kernels' constant tables) and the
// scalar reference FK (plain Eigen) the lane kernel is tested against.
#pragma once
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "kernels/human_kernels.hpp"

namespace atacom {

using HumanPose = std::array<double, kHumanPoseDim>;

struct HumanJoint {
  std::string name;
  int parent = -1;                    // -1: the root (pelvis)
  Eigen::Vector3d position;           // neutral pose, body frame
  int dof_begin = 0, dof_count = 0;   // pose indices of its angles
};

struct HumanDof {
  std::string name;
  int joint = 0;
  int axis = 0;                       // 0 = x, 1 = y, 2 = z, in the joint's frame
  double sign = 1.0;                  // rotation about sign * e_axis
  double lower = 0.0, upper = 0.0;    // limits, rad
};

struct HumanCapsule {
  std::string name;
  int joint = 0;                      // moves rigidly with this joint
  Eigen::Vector3d p0, p1;             // neutral pose, body frame
  double radius = 0.0;
};

struct HumanModel {
  double stature = 0.0;
  std::vector<HumanJoint> joints;     // (20) parents before children
  std::vector<HumanDof> dofs;         // (34) pose index = kHumanRootDofs + dof index
  std::vector<HumanCapsule> capsules; // (16)
  HumanFkConst fk{};                  // constant tables of the kernels

  int joint_index(const std::string& name) const;    // throws std::invalid_argument
  int capsule_index(const std::string& name) const;  // throws std::invalid_argument
  int pose_index(const std::string& dof_name) const; // kHumanRootDofs + dof; throws std::invalid_argument
  // Name of pose entry i ("x", "y", "z", "yaw", then the DoF names).
  std::string pose_name(int i) const;
  // Joint-angle limits per pose entry (root entries: -inf, +inf).
  double lower(int i) const;
  double upper(int i) const;
};

// Reads data_file("human_skeleton.json") and data_file("human_dofs.json");
// throws std::runtime_error naming the file and the inconsistency.
HumanModel load_human_model();

// Everything the FK derives from one pose (scalar reference).
struct HumanFkResult {
  std::vector<Eigen::Matrix3d> R, R_dot;     // (20) joint frames in the robot base frame
  std::vector<Eigen::Vector3d> p, p_dot;     // (20) joint positions and velocities
  std::vector<Eigen::Vector3d> a, b;         // (16) capsule end points
  std::vector<Eigen::Vector3d> va, vb;       // (16) their velocities
};

// pose: (38); pose_rate (38) or nullptr (velocities 0).
HumanFkResult human_fk_reference(const HumanModel& model, const double* pose, const double* pose_rate = nullptr);

}  // namespace atacom
