// NavEnv's ATACOM constraints, c(q, x) <= 0, k = 5 rows:
//   0  x - (room_x - r_T - m_w)      wall +x
//   1  y - (room_y - r_T - m_w)      wall +y
//   2  -x - (room_x - r_T - m_w)     wall -x
//   3  -y - (room_y - r_T - m_w)     wall -y
//   4  r_T + r_F + m_F - |p_T - p_F| TIAGo-Fetch clearance
// q = [x, y, theta] is TIAGo's pose (controllable), x = [x_F, y_F] is Fetch's
// position (uncontrollable, p = 2); Fetch's velocity xdot enters ATACOM's
// drift term J_x xdot. No row depends on theta, so J_q G of the unicycle has
// a zero omega column and a v column n_i . (cos theta, sin theta) that
// vanishes when obstacle i is exactly sideways (docs/envs_nav.md).
#pragma once

namespace atacom {

struct ProjectorBatch;
struct DiffDriveSystem;

inline constexpr int kNavConstraints = 5;  // k
inline constexpr int kNavFetchState = 2;   // p

struct NavConstraintGeometry {
  double room_x = 3.5;        // inner wall faces at x = +-room_x, m
  double room_y = 2.5;        // and y = +-room_y, m
  double tiago_radius = 0.4;  // r_T
  double fetch_radius = 0.3;  // r_F
  double wall_margin = 0.1;   // m_w
  double fetch_margin = 0.1;  // m_F
};

// One env: c (5), Jq (5 x 3) = dc/dq, Jx (5 x 2) = dc/dx, row-major.
// When the two centres coincide (never reached: contact ends the episode
// at |p_T - p_F| = r_T + r_F) the clearance gradient uses the fixed unit
// direction (1, 0) so the output stays finite.
void nav_constraints(const NavConstraintGeometry& g, const double* q, const double* xf, double* c, double* Jq,
                     double* Jx);

// Central finite-difference twin of the Jacobians (step h), for the tests.
void nav_constraints_fd(const NavConstraintGeometry& g, const double* q, const double* xf, double h, double* Jq,
                        double* Jx);

// Batched kernel over envs [begin, end): reads TIAGo poses tiago (N x 3),
// Fetch poses fetch (N x 3) and Fetch velocities fetch_vel (N x 3, world vx,
// vy, omega over the coming step) and writes f, G, c, Jq, Jx and xdot of pb
// (sized for n = 3, m = 2, k = 5, p = 2). No allocation.
void nav_constraint_model(const NavConstraintGeometry& g, const DiffDriveSystem& sys, const double* tiago,
                          const double* fetch, const double* fetch_vel, ProjectorBatch& pb, int begin, int end);

}  // namespace atacom
