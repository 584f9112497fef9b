#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "kernels/nav_constraints.hpp"
#include "envs/nav/nav_env.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "atacom/system.hpp"

using namespace atacom;

TEST_CASE("nav constraints: values at known poses", "[nav_constraints]") {
  const NavConstraintGeometry g;  // the task's rows
  double c[5], Jq[15], Jx[15];
  const double q[3] = {3.0, -1.0, 0.3}, xf[3] = {3.0, 0.0, 0.0};
  nav_constraints(g, q, xf, c, Jq, Jx);
  REQUIRE(c[0] == Approx(0.0).margin(1e-15));   // x = 3.5 - 0.4 - 0.1
  REQUIRE(c[1] == Approx(-3.0));                // y = -1 vs 2.0
  REQUIRE(c[2] == Approx(-6.0));
  REQUIRE(c[3] == Approx(-1.0));
  REQUIRE(c[4] == Approx(0.8 - 1.0));
  // Clearance gradient: TIAGo is below Fetch, moving it further down helps.
  REQUIRE(Jq[12] == Approx(0.0).margin(1e-15));
  REQUIRE(Jq[13] == Approx(1.0));
  REQUIRE(Jx[13] == Approx(-1.0));
  REQUIRE(Jx[14] == 0.0);  // no sweep: Fetch's heading does not matter
  REQUIRE(Jq[2] == 0.0);   // no look-ahead: theta does not matter
  REQUIRE(Jq[14] == 0.0);
}

TEST_CASE("nav constraints: ATACOM's rows at known poses and never below the task's rows", "[nav_constraints]") {
  NavConstraintGeometry g;
  g.wall_lookahead = 0.1;
  g.wall_buffer = 0.02;
  g.fetch_lookahead = 0.2;
  g.fetch_sweep = 0.7;
  double c[5], Jq[15], Jx[15];
  // TIAGo facing +x at x = 2.5; Fetch at (0.5, 0) facing +x: the segment
  // ends at x = 1.2, the look-ahead point is at 2.7.
  const double q[3] = {2.5, 0.0, 0.0}, xf[3] = {0.5, 0.0, 0.0};
  nav_constraints(g, q, xf, c, Jq, Jx);
  REQUIRE(c[0] == Approx(2.5 + 0.2 - (3.5 - 0.4 - 0.1 - 0.02)));  // x + d_W (1 + cos 0)
  REQUIRE(c[2] == Approx(-2.5 - (3.5 - 0.4 - 0.1 - 0.02)));       // facing away: exact plus buffer
  REQUIRE(c[1] == Approx(0.1 - (2.5 - 0.4 - 0.1 - 0.02)));        // sideways: d_W
  REQUIRE(c[4] == Approx(0.4 + 0.2 + 0.3 + 0.1 - (2.7 - 1.2)));
  REQUIRE(Jq[1 * 3 + 2] == Approx(0.1));  // turning towards +y raises the +y row
  REQUIRE(Jx[4 * 3 + 0] == Approx(1.0));  // segment end moves with Fetch
  REQUIRE(Jx[4 * 3 + 2] == Approx(0.0).margin(1e-15));
  // Random states: each of ATACOM's rows is >= the task's row.
  const NavConstraintGeometry task = nav_task_geometry(g);
  Rng rng(12, 0);
  for (int trial = 0; trial < 2000; ++trial) {
    const double qq[3] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0), rng.uniform(-M_PI, M_PI)};
    const double ff[3] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0), rng.uniform(-M_PI, M_PI)};
    double ct[5];
    nav_constraints(g, qq, ff, c, Jq, Jx);
    nav_constraints(task, qq, ff, ct, Jq, Jx);
    for (int r = 0; r < 5; ++r) REQUIRE(c[r] >= ct[r] - 1e-12);
  }
}

TEST_CASE("nav constraints: J_q and J_x match central finite differences", "[nav_constraints]") {
  // The task's rows, ATACOM's default rows, and a larger look-ahead/sweep.
  NavConstraintGeometry big;
  big.wall_lookahead = 0.4;
  big.wall_buffer = 0.05;
  big.fetch_lookahead = 0.5;
  big.fetch_sweep = 1.5;
  const NavConstraintGeometry geoms[3] = {NavConstraintGeometry{}, nav_constraint_geometry(default_nav_config()),
                                          big};
  Rng rng(11, 0);
  const double h = 1e-6;
  int on_segment = 0;
  for (const NavConstraintGeometry& g : geoms) {
    for (int trial = 0; trial < 1000; ++trial) {
      const double q[3] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0), rng.uniform(-M_PI, M_PI)};
      double xf[3] = {rng.uniform(-3.0, 3.0), rng.uniform(-2.0, 2.0), rng.uniform(-M_PI, M_PI)};
      double c[5], Jq[15], Jx[15], Fq[15], Fx[15];
      nav_constraints(g, q, xf, c, Jq, Jx);
      // FD needs the look-ahead point well off the swept segment.
      if (g.tiago_radius + g.fetch_lookahead + g.fetch_radius + g.fetch_margin - c[4] < 0.05) {
        xf[0] += 1.0;
        nav_constraints(g, q, xf, c, Jq, Jx);
      }
      const double sseg = Jx[14];  // nonzero when the closest point is inside the segment or at its end
      on_segment += sseg != 0.0;
      nav_constraints_fd(g, q, xf, h, Fq, Fx);
      for (int i = 0; i < 15; ++i) REQUIRE(Jq[i] == Approx(Fq[i]).margin(1e-6));
      for (int i = 0; i < 15; ++i) REQUIRE(Jx[i] == Approx(Fx[i]).margin(1e-6));
    }
  }
  REQUIRE(on_segment > 200);  // the sweep's heading entry was exercised
}

TEST_CASE("nav constraints: coincident centres give a finite unit gradient", "[nav_constraints]") {
  const NavConstraintGeometry g;
  double c[5], Jq[15], Jx[15];
  const double q[3] = {1.0, 1.0, 0.0}, xf[3] = {1.0, 1.0, 0.0};
  nav_constraints(g, q, xf, c, Jq, Jx);
  REQUIRE(c[4] == Approx(0.8));
  REQUIRE(std::hypot(Jq[12], Jq[13]) == Approx(1.0));
  REQUIRE(std::hypot(Jx[12], Jx[13]) == Approx(1.0));
  // ATACOM's rows: look-ahead point on the swept segment.
  const NavConstraintGeometry ga = nav_constraint_geometry(default_nav_config());
  const double xs[3] = {0.5, 1.0, 0.0};  // segment [0.5, 1.2] x {1}, point at (1.2, 1)
  nav_constraints(ga, q, xs, c, Jq, Jx);
  for (int i = 0; i < 15; ++i) REQUIRE(std::isfinite(Jq[i]));
  for (int i = 0; i < 15; ++i) REQUIRE(std::isfinite(Jx[i]));
  REQUIRE(std::hypot(Jq[12], Jq[13]) == Approx(1.0));
}

TEST_CASE("nav constraints: batched kernel equals the per-env function", "[nav_constraints]") {
  const NavConstraintGeometry g = nav_constraint_geometry(default_nav_config());
  const DiffDriveSystem sys;
  const int N = 9;
  ProjectorBatch pb;
  pb.N = N;
  pb.f.assign(N * 3, -1.0);
  pb.G.assign(N * 6, -1.0);
  pb.c.assign(N * 5, -1.0);
  pb.Jq.assign(N * 15, -1.0);
  pb.Jx.assign(N * 15, -1.0);
  pb.xdot.assign(N * 3, -1.0);
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
    double c[5], Jq[15], Jx[15], f[3], G[6];
    const double xf[3] = {fetch[3 * i], fetch[3 * i + 1], fetch[3 * i + 2]};
    nav_constraints(g, &tiago[3 * i], xf, c, Jq, Jx);
    sys.eval(&tiago[3 * i], f, G);
    for (int r = 0; r < 5; ++r) REQUIRE(pb.c[5 * i + r] == c[r]);
    for (int r = 0; r < 15; ++r) REQUIRE(pb.Jq[15 * i + r] == Jq[r]);
    for (int r = 0; r < 15; ++r) REQUIRE(pb.Jx[15 * i + r] == Jx[r]);
    for (int r = 0; r < 6; ++r) REQUIRE(pb.G[6 * i + r] == G[r]);
    for (int r = 0; r < 3; ++r) REQUIRE(pb.f[3 * i + r] == 0.0);
    for (int r = 0; r < 3; ++r) REQUIRE(pb.xdot[3 * i + r] == fvel[3 * i + r]);
  }
}

TEST_CASE("nav constraints: sideways obstacle (J_q G loses rank) keeps the projector finite and safe",
          "[nav_constraints]") {
  // TIAGo at the origin heading along +y (theta = pi/2 + delta); Fetch to its
  // side on +x, so the clearance row of J_q G is -v_max n.h = v_max sin(delta)
  // and vanishes at delta = 0; likewise the +x wall row when TIAGo sits on
  // the wall boundary heading along it. Sweep delta down to exact rank loss,
  // the clearance from inside to violated, and Fetch static / approaching /
  // passing; project random alphas and check every output.
  const NavConfig cfg = default_nav_config();
  const NavEnv env(cfg, 1);
  const ProjectorModel model = env.projector_model();
  // The task's rows, which do not depend on theta: they lose rank exactly
  // sideways. (ATACOM's default rows have an omega entry through the
  // look-ahead points; the projector must stay finite on both.)
  const NavConstraintGeometry g = nav_task_geometry(nav_constraint_geometry(cfg));
  const DiffDriveSystem sys = nav_tiago_system(cfg);
  const double dt = cfg.dt;
  // Largest one-step increase of a row whose J_q G entry is zero: the arc
  // leaves its tangent line by at most v w dt^2 / 2.
  const double second_order = 0.5 * sys.v_max * sys.w_max * dt * dt;

  const double deltas[] = {0.0, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6, 1e-3, -1e-3, 0.1, -0.1};
  const double clear[] = {-0.05, -1e-4, 0.0, 0.02};  // c of the clearance row
  const double fetch_vel[3][2] = {{0.0, 0.0}, {-0.7, 0.0}, {0.0, 0.7}};
  const int A = 64;
  Rng rng(31, 0);
  int bias_out = 0, cases = 0;
  for (int wall_case = 0; wall_case < 2; ++wall_case) {
    for (double delta : deltas) {
      for (double c4 : clear) {
        for (const auto& fv : fetch_vel) {
          ++cases;
          // wall_case 1: TIAGo on the +x wall boundary, Fetch on the -x side.
          const double x0 = wall_case ? g.room_x - g.tiago_radius - g.wall_margin : 0.0;
          const double side = wall_case ? -1.0 : 1.0;
          const double sep = g.tiago_radius + g.fetch_radius + g.fetch_margin - c4;
          const double q[3] = {x0, 0.0, M_PI / 2 + delta};
          const double fetch[3] = {x0 + side * sep, 0.0, 0.0};
          const double fvel[3] = {side * fv[0], fv[1], 0.0};
          ProjectorBatch pb(model, A);
          std::vector<double> tiago(3 * A), fetchs(3 * A), fvels(3 * A);
          for (int i = 0; i < A; ++i)
            for (int j = 0; j < 3; ++j) {
              tiago[3 * i + j] = q[j];
              fetchs[3 * i + j] = fetch[j];
              fvels[3 * i + j] = fvel[j];
            }
          nav_constraint_model(g, sys, tiago.data(), fetchs.data(), fvels.data(), pb, 0, A);
          for (int i = 0; i < A; ++i) {
            pb.alpha[2 * i] = rng.uniform(-1.0, 1.0);
            pb.alpha[2 * i + 1] = rng.uniform(-1.0, 1.0);
          }
          project_batch(model, pb);
          for (int i = 0; i < A; ++i) {
            INFO("wall " << wall_case << " delta " << delta << " c4 " << c4 << " fetch v (" << fvel[0] << ", "
                         << fvel[1] << ")");
            REQUIRE(std::isfinite(pb.a[2 * i]));
            REQUIRE(std::isfinite(pb.a[2 * i + 1]));
            for (int r = 0; r < 5; ++r) REQUIRE(std::isfinite(pb.slack_u[5 * i + r]));
            REQUIRE((pb.status[i] & kStatusModelNonFinite) == 0);
            if (pb.status[i] & kStatusBiasOutOfBounds) {
              ++bias_out;
              continue;  // a = b, the env clips it; checked finite above
            }
            REQUIRE(std::abs(pb.a[2 * i]) <= 1.0 + 1e-12);
            REQUIRE(std::abs(pb.a[2 * i + 1]) <= 1.0 + 1e-12);
            // Safety where the obstacle does not move: after the exact
            // unicycle step no row may rise by more than the arc's second-
            // order deviation (rows already violated must not get worse).
            if (fv[0] == 0.0 && fv[1] == 0.0) {
              const double v = sys.v_max * std::clamp(pb.a[2 * i], -1.0, 1.0);
              const double w = sys.w_max * std::clamp(pb.a[2 * i + 1], -1.0, 1.0);
              double qn[3];
              const double th = q[2] + w * dt;
              if (std::abs(w) > 1e-12) {
                qn[0] = q[0] + v / w * (std::sin(th) - std::sin(q[2]));
                qn[1] = q[1] - v / w * (std::cos(th) - std::cos(q[2]));
              } else {
                qn[0] = q[0] + v * dt * std::cos(q[2]);
                qn[1] = q[1] + v * dt * std::sin(q[2]);
              }
              qn[2] = th;
              double c0[5], c1[5], Jq[15], Jx[15];
              const double* xf = fetch;
              nav_constraints(g, q, xf, c0, Jq, Jx);
              nav_constraints(g, qn, xf, c1, Jq, Jx);
              for (int r = 0; r < 5; ++r)
                if (c0[r] > -0.01) REQUIRE(c1[r] <= c0[r] + second_order + 1e-12);
            }
          }
        }
      }
    }
  }
  // Exactly sideways the projector has nothing to push with (the row of J_q G
  // is zero, the slack absorbs the drift); just off sideways, cancelling a
  // closing Fetch needs |v| > 1 and the bias leaves the box (flagged).
  INFO(bias_out << " of " << cases * A << " projections had the bias out of bounds");
  REQUIRE(bias_out > 0);
}
