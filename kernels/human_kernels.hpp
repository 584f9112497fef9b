// Batched kernels of the capsule human (docs/human.md): its forward
// kinematics (capsule endpoints and their velocities from a pose and its
// rate), the arm-vs-human constraint rows, and the exact contact check.
//
// The constant tables (HumanFkConst, HumanRowsConst) are plain data built by
// envs/arm/human_model.cpp and envs/arm/human_rows.cpp; the kernels work over
// an env range [begin, end) of a HumanBatch, SIMD across envs in lane blocks
// of kernels/lanes.hpp, and never allocate.
//
// Pose layout (kHumanPoseDim = 38 numbers per env):
//   [0..3]   root: x, y (floor position in the robot's base frame, m), z
//            (vertical offset of the body frame, m), yaw (about +z, rad)
//   [4..37]  the 34 joint angles of data/human_dofs.json, rad
// pose_rate holds d pose / dt per second of env time.
#pragma once
#include <cstdint>
#include <vector>

namespace atacom {

inline constexpr int kHumanJoints = 20;    // joints of data/human_skeleton.json (root = pelvis)
inline constexpr int kHumanCapsules = 16;  // segments of data/human_skeleton.json
inline constexpr int kHumanCapStride = kHumanCapsules * 6;  // doubles per env in cap / cap_vel: a, b of each capsule
inline constexpr int kHumanDofs = 34;      // joint angles (data/human_dofs.json)
inline constexpr int kHumanRootDofs = 4;   // x, y, z, yaw
inline constexpr int kHumanPoseDim = kHumanRootDofs + kHumanDofs;

// Kinematic tables, in the body frame of the neutral pose.
struct HumanFkConst {
  int parent[kHumanJoints];               // parent joint, -1 for the root (pelvis); parents precede children
  double offset[kHumanJoints][3];         // joint position minus the parent's (root: pelvis in the body frame)
  int dof_begin[kHumanJoints];            // pose index of the joint's first angle
  int dof_count[kHumanJoints];            // 0..3 angles, applied in order about signed principal axes
  int axis[kHumanPoseDim];                // per pose index of a joint angle: 0 = x, 1 = y, 2 = z
  double sign[kHumanPoseDim];             // +-1: the rotation is about sign * e_axis
  uint8_t needed[kHumanJoints];           // 1: carries a capsule or is an ancestor of one
  int cap_joint[kHumanCapsules];          // joint the capsule moves with
  double cap_a[kHumanCapsules][3];        // end points relative to that joint's position, body frame
  double cap_b[kHumanCapsules][3];
  double cap_radius[kHumanCapsules];      // m
  double cap_inv_len2[kHumanCapsules];    // 1 / |b - a|^2 (0 for a sphere); segments are rigid
};

// Structure-of-arrays state of N humans (one per env).
struct HumanBatch {
  int N = 0;
  std::vector<double> pose;       // (N x 38)         written by human_motion_range (or the caller)
  std::vector<double> pose_rate;  // (N x 38)         d pose / dt, 1/s; written with pose
  std::vector<double> cap;        // (N x 16 x 2 x 3) capsule end points a, b in the robot base frame, m;
                                  //                  written by human_capsules_range
  std::vector<double> cap_vel;    // (N x 16 x 2 x 3) their velocities, m/s; written by human_capsules_range

  HumanBatch() = default;
  explicit HumanBatch(int n) { resize(n); }
  void resize(int n);
};

// Capsule end points (and velocities when with_velocity) of envs [begin, end)
// from pose and pose_rate. Runs on the calling thread.
void human_capsules_range(const HumanFkConst& k, HumanBatch& batch, int begin, int end, bool with_velocity = true);

// Rows of one group "points of interest vs the human", P points per env,
// each moved by nq controllable joints (docs/human.md):
//   d_i    = smin_j (|p_i - seg_j| - r_j)  over the 16 capsules (blend k)
//   c_i    = delta_i - d_i
//   Jq_i   = -grad_p d_i . J_poi,i                       (1 x nq)
//   dcdt_i = -dd_i/dt at fixed p_i = sum_j w_ij n_ij . v_ij  (the human's motion)
// with w_ij the smooth-min weights (sum 1), n_ij the unit direction from the
// nearest point of capsule j to p_i and v_ij that point's velocity.
inline constexpr int kHumanMaxPoi = 16;
inline constexpr int kHumanMaxNq = 8;
struct HumanRowsConst {
  int num_poi = 0;                 // P (<= kHumanMaxPoi)
  int nq = 0;                      // joints per Jacobian row (<= kHumanMaxNq)
  double delta[kHumanMaxPoi] = {}; // per point: row threshold, m (sphere radius + cover + margin)
  double blend = 0.0;              // k of the smooth minimum, m; 0 = exact min
};

// Envs [begin, end) of a batch whose cap / cap_vel are current. poi: (N x P x 3),
// J_poi: (N x P x 3 x nq) row-major; outputs c, dcdt (N x P), Jq (N x P x nq),
// d_exact (N x P, optional): the exact min over capsules. Calling thread.
void human_rows_range(const HumanRowsConst& k, const HumanFkConst& hk, const HumanBatch& batch, const double* poi,
                      const double* J_poi, double* c, double* Jq, double* dcdt, double* d_exact, int begin, int end);

// Exact signed distance between the segment [a, b] and the human whose
// capsules are cap (16 x 2 x 3, HumanBatch::cap layout of one env): the
// smallest segment-to-surface distance (subtract the segment's radius to
// test contact).
double human_segment_distance(const HumanFkConst& k, const double* cap, const double* a, const double* b);

// Exact contact: items are capsules (a == b for a sphere) of the robot in the
// robot base frame, per env (N x n_items x 2 x 3) with radii (n_items); an
// env is in contact when any item is closer than radius_item + radius_capsule
// to any human capsule (segment-segment distance, exact). Writes contact (N)
// and, when min_distance != nullptr, the smallest surface distance (N).
void human_contact_range(const HumanBatch& batch, const HumanFkConst& k, const double* items, const double* radii,
                         int n_items, uint8_t* contact, double* min_distance, int begin, int end);

}  // namespace atacom
