// TIAGo++ right arm: the constant kinematic and geometric model.
//
// Loaded once from data/tiago_arm.json (chain, limits, points of interest)
// and data/tiago_collision.json (ground-truth link capsules, body primitives,
// which PoI covers which capsule). The torso lift joint is fixed at
// `torso_lift` and folded into the first joint's origin, so the model has 7
// revolute joints. Frames: 0..6 = arm_right_1..7_link, 7 = gripper_right_link.
//
// Grasping frame: the envs use the ATACOM authors' fingertip frame
// (0.21 m below gripper_right_link, PAL's grasping-frame orientation), because
// the paper's distances are measured there; PAL's frame (0.12 m) is kept as
// grasp_pal for the FK tests.
#pragma once
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace atacom {

constexpr int kArmJoints = 7;
constexpr int kArmFrames = 8;       // 7 arm links + gripper_right_link
constexpr int kGripperFrame = 7;
constexpr int kArmPoi = 9;

struct RigidTransform {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  RigidTransform operator*(const RigidTransform& o) const { return {R * o.R, R * o.p + p}; }
  Eigen::Vector3d apply(const Eigen::Vector3d& v) const { return R * v + p; }
  RigidTransform inverse() const { return {R.transpose(), -(R.transpose() * p)}; }
};

// URDF origin: Trans(xyz) * Rz(yaw) Ry(pitch) Rx(roll), rpy = [roll, pitch, yaw].
RigidTransform urdf_origin(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy);

struct ArmPoi {
  std::string name;
  int frame = 0;                     // 0..7
  Eigen::Vector3d offset;            // in the frame
  double radius = 0.0;               // sourced collision-sphere radius (ground truth)
  bool body_check = true;            // ground-truth check against the robot body
  // The sphere lies inside a link capsule in every configuration (rigidly
  // attached to the capsule's body): the batched ground truth skips it.
  bool inside_capsule = false;
};

struct CoverPart {
  int poi = 0;                       // index into TiagoArmModel::poi
  double t0 = 0.0, t1 = 1.0;         // part of the capsule segment it covers
};

struct ArmCapsule {
  std::string name;
  int frame = 0;                     // 0..7
  Eigen::Vector3d a, b;              // segment end points in the frame
  double radius = 0.0;
  bool body_check = true;            // ground-truth check against the robot body
  std::vector<CoverPart> cover;
};

// Robot body in base_footprint for the model's torso value.
struct BodyGeometry {
  Eigen::Vector2d base_center;       // vertical cylinder
  double base_z0 = 0.0, base_z1 = 0.0, base_radius = 0.0;
  Eigen::Vector3d torso_center, torso_half;  // axis-aligned box
  Eigen::Vector3d head_center;       // sphere
  double head_radius = 0.0;
};

struct TiagoArmModel {
  double torso_lift = 0.0;                          // fixed torso_lift_joint value, m
  std::array<std::string, kArmJoints> joint_names;
  std::array<double, kArmJoints> lower{}, upper{};  // URDF position limits, rad
  std::array<double, kArmJoints> velocity{};        // URDF velocity limits, rad/s
  // Origin of joint i in frame i-1; frame -1 is base_footprint with the fixed
  // chain base_footprint -> torso_lift_link (torso at torso_lift) folded in.
  std::array<RigidTransform, kArmJoints> joint_origin;
  RigidTransform gripper_in_link7;                  // gripper_right_link in arm_right_7_link
  RigidTransform grasp_in_gripper;                  // fingertip grasping frame (envs)
  RigidTransform grasp_pal_in_gripper;              // PAL gripper_right_grasping_frame
  std::array<ArmPoi, kArmPoi> poi;
  std::vector<ArmCapsule> capsules;                 // ground-truth link geometry
  BodyGeometry body;
  // Smallest constraint radius per PoI such that d(PoI) >= radius implies the
  // capsule parts it covers (and its own sphere) are clear of an obstacle;
  // body_cover only counts parts checked against the body.
  std::array<double, kArmPoi> scene_cover{}, body_cover{};
  Eigen::Vector3d shoulder;                         // joint 1 origin in base_footprint
  double reach = 0.0;                               // upper bound of |p - shoulder| over the arm
  int poi_index(const std::string& name) const;     // throws std::invalid_argument
};

// Reads data_file("tiago_arm.json") and data_file("tiago_collision.json").
// Throws std::runtime_error on missing files or inconsistent data.
TiagoArmModel load_tiago_arm_model(double torso_lift);

// Upper bound of |s - p| over every position the PoI can take relative to
// the capsule's body (used for the cover radii; exposed for the tests).
double cover_distance(const TiagoArmModel& m, const ArmCapsule& cap, const Eigen::Vector3d& s_in_cap_frame, int poi);

}  // namespace atacom
