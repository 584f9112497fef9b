#include <catch2/catch.hpp>

#include <cmath>

#include "atacom/rng.hpp"
#include "atacom/system.hpp"

using namespace atacom;

TEST_CASE("system: viability Jacobian matches finite differences", "[system]") {
  // c(q) = [sin(q0) q1, q0^2 + cos(q1)], J = dc/dq, H = d(J qdot)/dq.
  auto c_of = [](const double* q, double* c) {
    c[0] = std::sin(q[0]) * q[1];
    c[1] = q[0] * q[0] + std::cos(q[1]);
  };
  auto J_of = [](const double* q, double* J) {
    J[0] = std::cos(q[0]) * q[1]; J[1] = std::sin(q[0]);
    J[2] = 2 * q[0];              J[3] = -std::sin(q[1]);
  };
  auto H_of = [](const double* q, const double* v, double* H) {
    // rows: d/dq of (J v)_i
    H[0] = -std::sin(q[0]) * q[1] * v[0] + std::cos(q[0]) * v[1];
    H[1] = std::cos(q[0]) * v[0];
    H[2] = 2 * v[0];
    H[3] = -std::cos(q[1]) * v[1];
  };
  const double K[2] = {0.7, 1.3};
  auto cv_of = [&](const double* x, double* cv) {  // x = [q; qdot]
    double c[2], J[4], H[4], Jv[8];
    c_of(x, c);
    J_of(x, J);
    H_of(x, x + 2, H);
    viability_constraint(2, 2, c, J, H, x + 2, K, cv, Jv);
  };
  Rng rng(3, 0);
  for (int trial = 0; trial < 50; ++trial) {
    double x[4];
    for (double& v : x) v = rng.uniform(-2, 2);
    double c[2], J[4], H[4], cv[2], Jv[8];
    c_of(x, c);
    J_of(x, J);
    H_of(x, x + 2, H);
    viability_constraint(2, 2, c, J, H, x + 2, K, cv, Jv);
    for (int col = 0; col < 4; ++col) {
      const double h = 1e-6;
      double xp[4], xm[4], cp[2], cm[2];
      for (int i = 0; i < 4; ++i) xp[i] = xm[i] = x[i];
      xp[col] += h;
      xm[col] -= h;
      cv_of(xp, cp);
      cv_of(xm, cm);
      for (int row = 0; row < 2; ++row) CHECK(Jv[row * 4 + col] == Approx((cp[row] - cm[row]) / (2 * h)).margin(1e-6));
    }
  }
}

TEST_CASE("system: control maps and Euler steps", "[system]") {
  DiffDriveSystem dd;
  double q[3] = {0, 0, M_PI / 2}, f[3], G[6];
  dd.eval(q, f, G);
  CHECK(G[0] == Approx(0).margin(1e-15));
  CHECK(G[2] == Approx(1.0));
  CHECK(G[5] == Approx(M_PI / 3));
  const double a[2] = {1.0, 0.0};
  euler_step(dd, q, a, 0.1, f, G);
  CHECK(q[1] == Approx(0.1));

  DoubleIntegratorSystem di{{2.0, 3.0}};
  double x[4] = {0, 0, 1, -1}, f4[4], G4[8];
  const double acc[2] = {0.5, 1.0};
  euler_step(di, x, acc, 0.1, f4, G4);
  CHECK(x[0] == Approx(0.1));
  CHECK(x[1] == Approx(-0.1));
  CHECK(x[2] == Approx(1.1));
  CHECK(x[3] == Approx(-0.7));

  BicycleSystem bk;
  double qb[4] = {0, 0, 0, 0.3}, fb[4], Gb[8];
  bk.eval(qb, fb, Gb);
  CHECK(Gb[4] == Approx(bk.v_max * std::tan(0.3) / bk.wheelbase));
  CHECK(Gb[7] == Approx(bk.steer_rate_max));

  VelocityArmSystem arm{{0.5, 1.0}};
  double qa[2] = {0, 0}, fa[2], Ga[4];
  arm.eval(qa, fa, Ga);
  CHECK(Ga[0] == 0.5);
  CHECK(Ga[1] == 0.0);
  CHECK(Ga[3] == 1.0);
}
