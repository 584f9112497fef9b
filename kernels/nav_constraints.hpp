// NavEnv's ATACOM constraints, c(q, x) <= 0, k = 5 rows. With h = (cos theta,
// sin theta), the look-ahead points p_W = p_T + d_W h, p_L = p_T + d_F h and
// Fetch's swept segment S = {p_F + s L h_F : s in [0, 1]}:
//   0  x_W + d_W - (room_x - r_T - m_w - b_w)      wall +x
//   1  y_W + d_W - (room_y - r_T - m_w - b_w)      wall +y
//   2  -x_W + d_W - (room_x - r_T - m_w - b_w)     wall -x
//   3  -y_W + d_W - (room_y - r_T - m_w - b_w)     wall -y
//   4  r_T + d_F + r_F + m_F - dist(p_L, S)        TIAGo-Fetch clearance
// q = [x, y, theta] is TIAGo's pose (controllable), x = [x_F, y_F, theta_F]
// is Fetch's pose (uncontrollable, p = 3); Fetch's velocity (vx, vy, omega)
// is xdot. The disc of radius r_T + d around a point d ahead covers TIAGo's
// disc, and S contains p_F, so every row is >= the task's row of the same
// geometry with d_W = d_F = L = b_w = 0 (nav_task_geometry), which the env
// reports. With d > 0 the rows depend on theta, so J_q G has an omega
// column and ATACOM can turn TIAGo (docs/envs_nav.md).
#pragma once

namespace atacom {

struct ProjectorBatch;
struct DiffDriveSystem;

inline constexpr int kNavConstraints = 5;  // k
inline constexpr int kNavFetchState = 3;   // p

struct NavConstraintGeometry {
  double room_x = 3.5;        // inner wall faces at x = +-room_x, m
  double room_y = 2.5;        // and y = +-room_y, m
  double tiago_radius = 0.4;  // r_T
  double fetch_radius = 0.3;  // r_F
  double wall_margin = 0.1;   // m_w
  double fetch_margin = 0.1;  // m_F
  // The defaults here are the task's rows (all zero); NavConfig holds
  // ATACOM's values.
  double wall_lookahead = 0.0;   // d_W: wall rows at p_T + d_W h, radius r_T + d_W
  double wall_buffer = 0.0;      // b_w: extra wall margin of ATACOM's rows
  double fetch_lookahead = 0.0;  // d_F: Fetch row from p_T + d_F h, radius r_T + d_F
  double fetch_sweep = 0.0;      // L: Fetch row keeps clear of p_F + [0, L] h_F
};

// The task's own rows (no look-ahead, no sweep) of the same geometry.
inline NavConstraintGeometry nav_task_geometry(NavConstraintGeometry g) {
  g.wall_lookahead = 0.0;
  g.fetch_lookahead = 0.0;
  g.fetch_sweep = 0.0;
  g.wall_buffer = 0.0;
  return g;
}

// One env: xf = Fetch's pose (3); c (5), Jq (5 x 3) = dc/dq, Jx (5 x 3) =
// dc/dx, row-major. When the look-ahead point lies exactly on the segment
// (a state of measure zero, deep inside the row: c = r_T + d_F + r_F + m_F)
// the clearance gradient uses the fixed unit direction (1, 0) so the output
// stays finite.
void nav_constraints(const NavConstraintGeometry& g, const double* q, const double* xf, double* c, double* Jq,
                     double* Jx);

// Central finite-difference twin of the Jacobians (step h), for the tests.
void nav_constraints_fd(const NavConstraintGeometry& g, const double* q, const double* xf, double h, double* Jq,
                        double* Jx);

// Batched kernel over envs [begin, end): reads TIAGo poses tiago (N x 3),
// Fetch poses fetch (N x 3) and Fetch velocities fetch_vel (N x 3, world vx,
// vy, omega over the coming step) and writes f, G, c, Jq, Jx and xdot of pb
// (sized for n = 3, m = 2, k = 5, p = 3; xdot = Fetch's vx, vy, omega). No
// allocation.
void nav_constraint_model(const NavConstraintGeometry& g, const DiffDriveSystem& sys, const double* tiago,
                          const double* fetch, const double* fetch_vel, ProjectorBatch& pb, int begin, int end);

}  // namespace atacom
