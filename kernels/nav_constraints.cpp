#include "atacom/nav_constraints.hpp"

#include <cmath>

#include "atacom/projector.hpp"
#include "atacom/system.hpp"

namespace atacom {

void nav_constraints(const NavConstraintGeometry& g, const double* q, const double* xf, double* c, double* Jq,
                     double* Jx) {
  const double wx = g.room_x - g.tiago_radius - g.wall_margin;
  const double wy = g.room_y - g.tiago_radius - g.wall_margin;
  c[0] = q[0] - wx;
  c[1] = q[1] - wy;
  c[2] = -q[0] - wx;
  c[3] = -q[1] - wy;
  const double dx = q[0] - xf[0], dy = q[1] - xf[1];
  const double d = std::sqrt(dx * dx + dy * dy);
  c[4] = g.tiago_radius + g.fetch_radius + g.fetch_margin - d;
  // Unit vector from Fetch to TIAGo; fixed direction at coincidence.
  double nx = 1.0, ny = 0.0;
  if (d > 1e-12) { nx = dx / d; ny = dy / d; }
  const double jq[kNavConstraints][3] = {
      {1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {-1.0, 0.0, 0.0}, {0.0, -1.0, 0.0}, {-nx, -ny, 0.0}};
  const double jx[kNavConstraints][2] = {{0.0, 0.0}, {0.0, 0.0}, {0.0, 0.0}, {0.0, 0.0}, {nx, ny}};
  for (int i = 0; i < kNavConstraints; ++i) {
    for (int j = 0; j < 3; ++j) Jq[i * 3 + j] = jq[i][j];
    for (int j = 0; j < 2; ++j) Jx[i * 2 + j] = jx[i][j];
  }
}

void nav_constraints_fd(const NavConstraintGeometry& g, const double* q, const double* xf, double h, double* Jq,
                        double* Jx) {
  double cp[kNavConstraints], cm[kNavConstraints], scratch_q[15], scratch_x[10];
  for (int j = 0; j < 3; ++j) {
    double qp[3] = {q[0], q[1], q[2]}, qm[3] = {q[0], q[1], q[2]};
    qp[j] += h;
    qm[j] -= h;
    nav_constraints(g, qp, xf, cp, scratch_q, scratch_x);
    nav_constraints(g, qm, xf, cm, scratch_q, scratch_x);
    for (int i = 0; i < kNavConstraints; ++i) Jq[i * 3 + j] = (cp[i] - cm[i]) / (2.0 * h);
  }
  for (int j = 0; j < 2; ++j) {
    double xp[2] = {xf[0], xf[1]}, xm[2] = {xf[0], xf[1]};
    xp[j] += h;
    xm[j] -= h;
    nav_constraints(g, q, xp, cp, scratch_q, scratch_x);
    nav_constraints(g, q, xm, cm, scratch_q, scratch_x);
    for (int i = 0; i < kNavConstraints; ++i) Jx[i * 2 + j] = (cp[i] - cm[i]) / (2.0 * h);
  }
}

void nav_constraint_model(const NavConstraintGeometry& g, const DiffDriveSystem& sys, const double* tiago,
                          const double* fetch, const double* fetch_vel, ProjectorBatch& pb, int begin, int end) {
  constexpr int n = 3, m = 2, k = kNavConstraints, p = kNavFetchState;
  for (int i = begin; i < end; ++i) {
    const double* q = tiago + 3 * i;
    const double xf[2] = {fetch[3 * i], fetch[3 * i + 1]};
    double f[n];
    sys.eval(q, f, pb.G.data() + n * m * i);
    // f is zero (has_drift = false); fill it anyway when the batch holds it.
    if (pb.f.size() >= static_cast<size_t>(n) * (i + 1))
      for (int j = 0; j < n; ++j) pb.f[n * i + j] = f[j];
    nav_constraints(g, q, xf, pb.c.data() + k * i, pb.Jq.data() + k * n * i, pb.Jx.data() + k * p * i);
    pb.xdot[p * i] = fetch_vel[3 * i];
    pb.xdot[p * i + 1] = fetch_vel[3 * i + 1];
  }
}

}  // namespace atacom
