#include <catch2/catch.hpp>

#include <cmath>

#include "atacom/nav_constraints.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "atacom/system.hpp"

using namespace atacom;

TEST_CASE("nav constraints: values at known poses", "[nav_constraints]") {
  const NavConstraintGeometry g;
  double c[5], Jq[15], Jx[10];
  const double q[3] = {3.0, -1.0, 0.3}, xf[2] = {3.0, 0.0};
  nav_constraints(g, q, xf, c, Jq, Jx);
  REQUIRE(c[0] == Approx(0.0).margin(1e-15));   // x = 3.5 - 0.4 - 0.1
  REQUIRE(c[1] == Approx(-3.0));                // y = -1 vs 2.0
  REQUIRE(c[2] == Approx(-6.0));
  REQUIRE(c[3] == Approx(-1.0));
  REQUIRE(c[4] == Approx(0.8 - 1.0));
  // Clearance gradient: TIAGo is below Fetch, moving it further down helps.
  REQUIRE(Jq[12] == Approx(0.0).margin(1e-15));
  REQUIRE(Jq[13] == Approx(1.0));
  REQUIRE(Jx[9] == Approx(-1.0));
}

TEST_CASE("nav constraints: J_q and J_x match central finite differences", "[nav_constraints]") {
  const NavConstraintGeometry g;
  Rng rng(11, 0);
  const double h = 1e-6;
  for (int trial = 0; trial < 500; ++trial) {
    const double q[3] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0), rng.uniform(-M_PI, M_PI)};
    double xf[2] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0)};
    if (std::hypot(q[0] - xf[0], q[1] - xf[1]) < 0.05) xf[0] += 0.5;  // FD needs |p_T - p_F| >> h
    double c[5], Jq[15], Jx[10], Fq[15], Fx[10];
    nav_constraints(g, q, xf, c, Jq, Jx);
    nav_constraints_fd(g, q, xf, h, Fq, Fx);
    for (int i = 0; i < 15; ++i) REQUIRE(Jq[i] == Approx(Fq[i]).margin(1e-6));
    for (int i = 0; i < 10; ++i) REQUIRE(Jx[i] == Approx(Fx[i]).margin(1e-6));
  }
}

TEST_CASE("nav constraints: coincident centres give a finite unit gradient", "[nav_constraints]") {
  const NavConstraintGeometry g;
  double c[5], Jq[15], Jx[10];
  const double q[3] = {1.0, 1.0, 0.0}, xf[2] = {1.0, 1.0};
  nav_constraints(g, q, xf, c, Jq, Jx);
  REQUIRE(c[4] == Approx(0.8));
  REQUIRE(std::hypot(Jq[12], Jq[13]) == Approx(1.0));
  REQUIRE(std::hypot(Jx[8], Jx[9]) == Approx(1.0));
}

TEST_CASE("nav constraints: batched kernel equals the per-env function", "[nav_constraints]") {
  const NavConstraintGeometry g;
  const DiffDriveSystem sys;
  const int N = 9;
  ProjectorBatch pb;
  pb.N = N;
  pb.f.assign(N * 3, -1.0);
  pb.G.assign(N * 6, -1.0);
  pb.c.assign(N * 5, -1.0);
  pb.Jq.assign(N * 15, -1.0);
  pb.Jx.assign(N * 10, -1.0);
  pb.xdot.assign(N * 2, -1.0);
  std::vector<double> tiago(3 * N), fetch(3 * N), fvel(3 * N);
  Rng rng(5, 1);
  for (auto& v : tiago) v = rng.uniform(-2.0, 2.0);
  for (auto& v : fetch) v = rng.uniform(-2.0, 2.0);
  for (auto& v : fvel) v = rng.uniform(-0.7, 0.7);
  nav_constraint_model(g, sys, tiago.data(), fetch.data(), fvel.data(), pb, 2, 7);
  for (int i = 0; i < N; ++i) {
    if (i < 2 || i >= 7) {  // outside the range: untouched
      REQUIRE(pb.c[5 * i] == -1.0);
      continue;
    }
    double c[5], Jq[15], Jx[10], f[3], G[6];
    const double xf[2] = {fetch[3 * i], fetch[3 * i + 1]};
    nav_constraints(g, &tiago[3 * i], xf, c, Jq, Jx);
    sys.eval(&tiago[3 * i], f, G);
    for (int r = 0; r < 5; ++r) REQUIRE(pb.c[5 * i + r] == c[r]);
    for (int r = 0; r < 15; ++r) REQUIRE(pb.Jq[15 * i + r] == Jq[r]);
    for (int r = 0; r < 10; ++r) REQUIRE(pb.Jx[10 * i + r] == Jx[r]);
    for (int r = 0; r < 6; ++r) REQUIRE(pb.G[6 * i + r] == G[r]);
    for (int r = 0; r < 3; ++r) REQUIRE(pb.f[3 * i + r] == 0.0);
    REQUIRE(pb.xdot[2 * i] == fvel[3 * i]);
    REQUIRE(pb.xdot[2 * i + 1] == fvel[3 * i + 1]);
  }
}
