#include "kernels/nav_constraints.hpp"

#include <algorithm>
#include <cmath>

#include "atacom/projector.hpp"
#include "atacom/system.hpp"

namespace atacom {

void nav_constraints(const NavConstraintGeometry& g, const double* q, const double* xf, double* c, double* Jq,
                     double* Jx) {
  const double ct = std::cos(q[2]), st = std::sin(q[2]);
  const double dw = g.wall_lookahead, df = g.fetch_lookahead;
  const double wx = g.room_x - g.tiago_radius - g.wall_margin - g.wall_buffer;
  const double wy = g.room_y - g.tiago_radius - g.wall_margin - g.wall_buffer;
  // Wall rows at the look-ahead point p_T + d_W h with radius r_T + d_W:
  // x + d_W (1 + cos theta) <= room - r_T - m_w - buffer (and likewise).
  const double pen[4] = {dw * (1.0 + ct), dw * (1.0 + st), dw * (1.0 - ct), dw * (1.0 - st)};
  const double dpen[4] = {-dw * st, dw * ct, dw * st, -dw * ct};
  c[0] = q[0] - wx + pen[0];
  c[1] = q[1] - wy + pen[1];
  c[2] = -q[0] - wx + pen[2];
  c[3] = -q[1] - wy + pen[3];
  // Fetch row: distance from TIAGo's look-ahead point to the segment
  // p_F + s L h_F, s in [0, 1], ahead of Fetch along its heading. The
  // distance to a segment is C^1 in its end points wherever it is > 0
  // (envelope theorem: the closest-point parameter may be held fixed).
  const double px = q[0] + df * ct, py = q[1] + df * st;
  const double L = g.fetch_sweep;
  const double cf = std::cos(xf[2]), sf = std::sin(xf[2]);
  const double ex = L * cf, ey = L * sf;
  const double L2 = ex * ex + ey * ey;
  double sseg = 0.0;
  if (L2 > 1e-18) sseg = std::clamp(((px - xf[0]) * ex + (py - xf[1]) * ey) / L2, 0.0, 1.0);
  const double dx = px - (xf[0] + sseg * ex), dy = py - (xf[1] + sseg * ey);
  const double d = std::sqrt(dx * dx + dy * dy);
  c[4] = g.tiago_radius + df + g.fetch_radius + g.fetch_margin - d;
  // Unit vector from the closest segment point to TIAGo; fixed direction at coincidence.
  double nx = 1.0, ny = 0.0;
  if (d > 1e-12) { nx = dx / d; ny = dy / d; }
  const double jq[kNavConstraints][3] = {{1.0, 0.0, dpen[0]},
                                         {0.0, 1.0, dpen[1]},
                                         {-1.0, 0.0, dpen[2]},
                                         {0.0, -1.0, dpen[3]},
                                         {-nx, -ny, -df * (-nx * st + ny * ct)}};
  constexpr int p = kNavFetchState;
  for (int i = 0; i < kNavConstraints; ++i) {
    for (int j = 0; j < 3; ++j) Jq[i * 3 + j] = jq[i][j];
    for (int j = 0; j < p; ++j) Jx[i * p + j] = 0.0;
  }
  Jx[4 * p + 0] = nx;
  Jx[4 * p + 1] = ny;
  Jx[4 * p + 2] = sseg * L * (-nx * sf + ny * cf);
}

void nav_constraints_fd(const NavConstraintGeometry& g, const double* q, const double* xf, double h, double* Jq,
                        double* Jx) {
  double cp[kNavConstraints], cm[kNavConstraints];
  double scratch_q[3 * kNavConstraints], scratch_x[kNavFetchState * kNavConstraints];
  for (int j = 0; j < 3; ++j) {
    double qp[3] = {q[0], q[1], q[2]}, qm[3] = {q[0], q[1], q[2]};
    qp[j] += h;
    qm[j] -= h;
    nav_constraints(g, qp, xf, cp, scratch_q, scratch_x);
    nav_constraints(g, qm, xf, cm, scratch_q, scratch_x);
    for (int i = 0; i < kNavConstraints; ++i) Jq[i * 3 + j] = (cp[i] - cm[i]) / (2.0 * h);
  }
  constexpr int p = kNavFetchState;
  for (int j = 0; j < p; ++j) {
    double xp[p], xm[p];
    for (int l = 0; l < p; ++l) xp[l] = xm[l] = xf[l];
    xp[j] += h;
    xm[j] -= h;
    nav_constraints(g, q, xp, cp, scratch_q, scratch_x);
    nav_constraints(g, q, xm, cm, scratch_q, scratch_x);
    for (int i = 0; i < kNavConstraints; ++i) Jx[i * p + j] = (cp[i] - cm[i]) / (2.0 * h);
  }
}

void nav_constraint_model(const NavConstraintGeometry& g, const DiffDriveSystem& sys, const double* tiago,
                          const double* fetch, const double* fetch_vel, ProjectorBatch& pb, int begin, int end) {
  constexpr int n = 3, m = 2, k = kNavConstraints, p = kNavFetchState;
  for (int i = begin; i < end; ++i) {
    const double* q = tiago + 3 * i;
    const double xf[p] = {fetch[3 * i], fetch[3 * i + 1], fetch[3 * i + 2]};
    double f[n];
    sys.eval(q, f, pb.G.data() + n * m * i);
    // f is zero (has_drift = false); fill it anyway when the batch holds it.
    if (pb.f.size() >= static_cast<size_t>(n) * (i + 1))
      for (int j = 0; j < n; ++j) pb.f[n * i + j] = f[j];
    nav_constraints(g, q, xf, pb.c.data() + k * i, pb.Jq.data() + k * n * i, pb.Jx.data() + k * p * i);
    pb.xdot[p * i] = fetch_vel[3 * i];
    pb.xdot[p * i + 1] = fetch_vel[3 * i + 1];
    pb.xdot[p * i + 2] = fetch_vel[3 * i + 2];
  }
}

}  // namespace atacom
