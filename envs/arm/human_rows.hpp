// Row group "points of interest vs the human" and the exact human contact
// check: the constant table of the batched kernels (kernels/human_kernels.hpp)
// and slow, obvious scalar references (plain Eigen, kernels/sdf shapes)
// that the kernels are tested against.
//
// Row i of the group: c_i = delta_i - d_i(q, t) <= 0, where d_i is the
// smooth minimum over the 16 capsules of the signed distance of PoI i.
//   J_q  = -grad_p d_i . J_poi,i
//   dc/dt from the human's motion alone (the robot held still).
// For the projector the human's state is its motion time: x = t (p = 1),
// J_x = dc/dt and xdot = 1 per second of env time, so J_x xdot is the drift
// the projector compensates (docs/human.md).
//
// Smooth-minimum error (polynomial smooth min with parameter k = blend,
// folded over the capsules in model order, kernels/sdf.hpp):
//   min_j d_j - 15 k / 4  <=  d_i  <=  min_j d_j,
// and d_i equals the exact minimum wherever the nearest capsule is at least
// (M + 2) k / 4 = 4.5 k nearer than every other one (the capsules folded
// before it lower the running value by at most (M - 2) k / 4, and a pair
// step is exact when its two values differ by k). Since d_i never exceeds
// the exact distance, c_i <= 0 still guarantees min_j d_j >= delta_i.
#pragma once
#include <vector>

#include <Eigen/Core>

#include "envs/arm/human_model.hpp"
#include "kernels/human_kernels.hpp"

namespace atacom {

// The one factory: P points with thresholds delta (m), nq joints, blend k (m).
// Throws std::invalid_argument on sizes outside the kernel's bounds or bad values.
HumanRowsConst make_human_rows(const std::vector<double>& delta, int nq, double blend);

// Worst-case gap between the smooth and the exact minimum over the capsules.
inline double human_smooth_min_error_bound(double blend) { return (kHumanCapsules - 1) * blend / 4.0; }
// Gap between the nearest and the second nearest capsule beyond which the
// smooth minimum is the exact one.
inline double human_smooth_min_exact_gap(double blend) { return (kHumanCapsules + 2) * blend / 4.0; }

struct HumanRowsReference {
  Eigen::VectorXd c;        // (P)
  Eigen::MatrixXd Jq;       // (P x nq)
  Eigen::VectorXd dcdt;     // (P) from the human's motion, robot still
  Eigen::VectorXd d_exact;  // (P) exact minimum distance over the capsules
};

// One env: capsules from human_fk_reference (with velocities), PoI positions
// (P) and Jacobians (P of 3 x nq). d and grad by union_distance of
// kernels/sdf.hpp; dc/dt by central differences of it along the capsules'
// velocities (step h seconds), so it shares no code with the kernel.
HumanRowsReference human_rows_reference(const HumanModel& model, const HumanRowsConst& rows, const HumanFkResult& human,
                                        const std::vector<Eigen::Vector3d>& poi,
                                        const std::vector<Eigen::MatrixXd>& J_poi, double h = 1e-7);

// A robot part for the contact check: capsule a-b (a == b: sphere).
struct RobotPart {
  Eigen::Vector3d a, b;
  double radius = 0.0;
};

// Exact smallest surface distance between the robot parts and the human's
// capsules (negative: penetration), by golden-section segment distances
// (kernels/sdf.hpp segment_distance); contact when it is < 0.
double human_min_distance_reference(const HumanModel& model, const HumanFkResult& human,
                                    const std::vector<RobotPart>& parts);

}  // namespace atacom
