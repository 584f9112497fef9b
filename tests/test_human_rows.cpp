// Arm-vs-human rows and contacts: capsule distances and gradients against
// dense sampling and finite differences, the smooth minimum's error bound,
// segment-segment distances against brute force, the batched rows and
// contact kernels against their scalar references, and J_x xdot against the
// finite-difference time derivative of the rows along replayed motion with
// the robot held still.
#include <catch2/catch.hpp>

#include <cmath>

#include "atacom/rng.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_rows.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "envs/arm/tiago_model.hpp"
#include "kernels/human_kernels.hpp"
#include "envs/arm/arm_fk_lanes.hpp"
#include "kernels/human_fk_lanes.hpp"
#include "kernels/human_rows_lanes.hpp"
#include "tests/build_kind.hpp"
#include "tests/loaded_human.hpp"

using namespace atacom;
using Eigen::Vector3d;

namespace {

Vector3d rand_vec(Rng& rng, double r) { return {rng.uniform(-r, r), rng.uniform(-r, r), rng.uniform(-r, r)}; }

HumanPose half_range_pose(Rng& rng) {
  const HumanModel& m = human_model();
  HumanPose p{};
  p[0] = rng.uniform(0.6, 1.0);
  p[1] = rng.uniform(-0.3, 0.3);
  p[3] = rng.uniform(-3.2, 3.2);
  for (int i = kHumanRootDofs; i < kHumanPoseDim; ++i) p[i] = rng.uniform(m.lower(i), m.upper(i)) * 0.5;
  return p;
}
HumanPose moderate_rate(Rng& rng) {
  HumanPose r{};
  for (int i = 0; i < kHumanPoseDim; ++i) r[i] = rng.uniform(-1.5, 1.5);
  return r;
}

// Distance of p to a capsule by dense sampling of its axis.
double sampled_capsule_distance(const Vector3d& a, const Vector3d& b, double radius, const Vector3d& p, int n = 200000) {
  double best = INFINITY;
  for (int i = 0; i <= n; ++i) best = std::min(best, (p - (a + (b - a) * (double(i) / n))).norm());
  return best - radius;
}

// Stores one human's capsules into env e of a batch.
void put_human(HumanBatch& B, int e, const HumanFkResult& fk) {
  for (int c = 0; c < kHumanCapsules; ++c) {
    double* cap = &B.cap[(static_cast<size_t>(e) * kHumanCapsules + c) * 6];
    double* vel = &B.cap_vel[(static_cast<size_t>(e) * kHumanCapsules + c) * 6];
    const size_t sc = static_cast<size_t>(c);
    for (int r = 0; r < 3; ++r) {
      cap[r] = fk.a[sc](r);
      cap[3 + r] = fk.b[sc](r);
      vel[r] = fk.va[sc](r);
      vel[3 + r] = fk.vb[sc](r);
    }
  }
}

}  // namespace

TEST_CASE("human capsule distance matches dense sampling, its gradient finite differences", "[human]") {
  Rng rng(11, 0);
  for (int trial = 0; trial < 30; ++trial) {
    const Vector3d a = rand_vec(rng, 0.5), b = trial % 5 == 0 ? a : Vector3d(rand_vec(rng, 0.5));
    const double r = rng.uniform(0.03, 0.2), inv = (b - a).squaredNorm() > 0 ? 1.0 / (b - a).squaredNorm() : 0.0;
    const Vector3d p = rand_vec(rng, 0.8);
    double n[3], h;
    const double d = human_impl::capsule_distance<double>(a.data(), b.data(), inv, r, p.data(), n, h);
    CHECK(std::abs(d - sampled_capsule_distance(a, b, r, p)) < 1e-5);  // sampling resolution |b - a| / 2e5
    const double eps = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vector3d pp = p, pm = p;
      pp(k) += eps;
      pm(k) -= eps;
      double nn[3], hh;
      const double dp = human_impl::capsule_distance<double>(a.data(), b.data(), inv, r, pp.data(), nn, hh);
      const double dm = human_impl::capsule_distance<double>(a.data(), b.data(), inv, r, pm.data(), nn, hh);
      CHECK(std::abs((dp - dm) / (2 * eps) - n[k]) < 1e-5);
    }
  }
}

TEST_CASE("human smooth minimum: within its bound below the exact min, exact when one capsule is nearest", "[human]") {
  const HumanModel& m = human_model();
  Rng rng(12, 0);
  CHECK(human_smooth_min_error_bound(0.02) == Approx(15 * 0.02 / 4));
  for (const double k : {0.01, 0.04}) {
  const double bound = human_smooth_min_error_bound(k);
  int exact_cases = 0;
  double worst_gap = 0;
  for (int trial = 0; trial < 150; ++trial) {
    const HumanPose pose = half_range_pose(rng), rate = moderate_rate(rng);
    const HumanFkResult fk = human_fk_reference(m, pose.data(), rate.data());
    const Vector3d p = Vector3d(pose[0], pose[1], 1.0) + rand_vec(rng, 0.7);
    double A[kHumanCapsules][3], B[kHumanCapsules][3], VA[kHumanCapsules][3], VB[kHumanCapsules][3];
    for (size_t c = 0; c < kHumanCapsules; ++c)
      for (int r = 0; r < 3; ++r) {
        A[c][r] = fk.a[c](r);
        B[c][r] = fk.b[c](r);
        VA[c][r] = fk.va[c](r);
        VB[c][r] = fk.vb[c](r);
      }
    double g[3], ddt, dex;
    const double d = human_impl::human_point_distance<double>(A, B, VA, VB, m.fk.cap_inv_len2, m.fk.cap_radius, k,
                                                              p.data(), g, ddt, dex);
    // Exact min by dense sampling, the second nearest for the exactness claim.
    std::vector<double> dc;
    for (size_t c = 0; c < kHumanCapsules; ++c)
      dc.push_back(sampled_capsule_distance(fk.a[c], fk.b[c], m.capsules[c].radius, p, 10000));
    std::sort(dc.begin(), dc.end());
    CHECK(std::abs(dex - dc[0]) < 5e-5);
    CHECK(d <= dex + 1e-15);
    CHECK(d >= dex - bound - 1e-12);
    worst_gap = std::max(worst_gap, dex - d);
    if (dc[1] - dc[0] > human_smooth_min_exact_gap(k) + 1e-4) {
      ++exact_cases;
      CHECK(d == Approx(dex).margin(1e-12));
    }
    // Gradient of the smooth distance against finite differences.
    const double eps = 1e-6;
    for (int r = 0; r < 3; ++r) {
      Vector3d pp = p, pm = p;
      pp(r) += eps;
      pm(r) -= eps;
      double gg[3], tt, xx;
      const double dp = human_impl::human_point_distance<double>(A, B, VA, VB, m.fk.cap_inv_len2, m.fk.cap_radius, k,
                                                                 pp.data(), gg, tt, xx);
      const double dm = human_impl::human_point_distance<double>(A, B, VA, VB, m.fk.cap_inv_len2, m.fk.cap_radius, k,
                                                                 pm.data(), gg, tt, xx);
      CHECK(std::abs((dp - dm) / (2 * eps) - g[r]) < 2e-5);
    }
  }
  INFO("k " << k << ": worst smooth-vs-exact gap " << worst_gap << " m, bound " << bound << ", exact cases "
              << exact_cases);
  CHECK(exact_cases > (k < 0.02 ? 10 : 0));
  CHECK(worst_gap > 0.0);
  CHECK(worst_gap <= bound);
  }
}

TEST_CASE("segment-segment distance matches brute force, also for points and parallel segments", "[human]") {
  Rng rng(13, 0);
  // The brute force is the cost (200k distances a trial); a quarter of the trials under the sanitizers still
  // holds every special case below (trial 0 is all of them, then multiples of 7, 11, 13 and 17).
  for (int trial = 0; trial < sanitizer_scaled(200); ++trial) {
    Vector3d p1 = rand_vec(rng, 0.5), q1 = rand_vec(rng, 0.5), p2 = rand_vec(rng, 0.5), q2 = rand_vec(rng, 0.5);
    if (trial % 7 == 0) q1 = p1;                             // point vs segment
    if (trial % 11 == 0) q2 = p2;                            // segment vs point
    if (trial % 13 == 0) q2 = p2 + 0.7 * (q1 - p1);          // parallel
    if (trial % 17 == 0) q2 = p2 = p1 + 0.3 * (q1 - p1);     // point on the segment
    double s, t;
    const double d = std::sqrt(human_impl::segment_segment_distance2(p1.data(), q1.data(), p2.data(), q2.data(), &s, &t));
    CHECK(s >= 0.0);
    CHECK(s <= 1.0);
    CHECK(t >= 0.0);
    CHECK(t <= 1.0);
    CHECK(std::abs(d - ((p1 + s * (q1 - p1)) - (p2 + t * (q2 - p2))).norm()) < 1e-12);
    // Brute force: a 400 x 400 grid, then refine around its best cell.
    double best = INFINITY, bs = 0, bt = 0;
    for (int i = 0; i <= 400; ++i)
      for (int j = 0; j <= 400; ++j) {
        const double x = ((p1 + (i / 400.0) * (q1 - p1)) - (p2 + (j / 400.0) * (q2 - p2))).norm();
        if (x < best) {
          best = x;
          bs = i / 400.0;
          bt = j / 400.0;
        }
      }
    for (int i = -100; i <= 100; ++i)
      for (int j = -100; j <= 100; ++j) {
        const double si = std::clamp(bs + i * 5e-5, 0.0, 1.0), tj = std::clamp(bt + j * 5e-5, 0.0, 1.0);
        best = std::min(best, ((p1 + si * (q1 - p1)) - (p2 + tj * (q2 - p2))).norm());
      }
    CHECK(d <= best + 1e-12);
    CHECK(d >= best - 1e-6);
  }
}

TEST_CASE("human rows kernel matches the scalar reference for every env of a range", "[human]") {
  const HumanModel& m = human_model();
  Rng rng(14, 0);
  const int N = 19, P = 9, nq = 7;
  std::vector<double> delta(P);
  for (double& d : delta) d = rng.uniform(0.05, 0.2);
  const HumanRowsConst rows = make_human_rows(delta, nq, 0.02);
  HumanBatch B(N);
  std::vector<HumanFkResult> humans;
  std::vector<double> poi(static_cast<size_t>(N) * P * 3), J(static_cast<size_t>(N) * P * 3 * nq);
  for (int e = 0; e < N; ++e) {
    const HumanPose pose = half_range_pose(rng), rate = moderate_rate(rng);
    humans.push_back(human_fk_reference(m, pose.data(), rate.data()));
    put_human(B, e, humans.back());
    for (int i = 0; i < P; ++i) {
      const Vector3d p = Vector3d(pose[0], pose[1], 1.0) + rand_vec(rng, 0.6);
      for (int r = 0; r < 3; ++r) poi[(static_cast<size_t>(e) * P + i) * 3 + r] = p(r);
    }
  }
  for (double& x : J) x = rng.uniform(-1, 1);
  std::vector<double> c(static_cast<size_t>(N) * P, 7.0), Jq(static_cast<size_t>(N) * P * nq, 7.0), dcdt(c), dex(c);
  human_rows_range(rows, m.fk, B, poi.data(), J.data(), c.data(), Jq.data(), dcdt.data(), dex.data(), 2, N);
  double worst = 0, worst_dt = 0;
  for (int e = 0; e < N; ++e) {
    std::vector<Vector3d> pe;
    std::vector<Eigen::MatrixXd> Je;
    for (int i = 0; i < P; ++i) {
      pe.emplace_back(&poi[(static_cast<size_t>(e) * P + i) * 3]);
      Je.push_back(Eigen::Map<const Eigen::Matrix<double, 3, 7, Eigen::RowMajor>>(&J[(static_cast<size_t>(e) * P + i) * 3 * nq]));
    }
    const HumanRowsReference ref = human_rows_reference(m, rows, humans[static_cast<size_t>(e)], pe, Je);
    for (int i = 0; i < P; ++i) {
      const size_t k = static_cast<size_t>(e) * P + i;
      if (e < 2) {  // outside the range: untouched
        CHECK(c[k] == 7.0);
        continue;
      }
      worst = std::max({worst, std::abs(c[k] - ref.c(i)), std::abs(dex[k] - ref.d_exact(i))});
      for (int j = 0; j < nq; ++j) worst = std::max(worst, std::abs(Jq[k * nq + j] - ref.Jq(i, j)));
      worst_dt = std::max(worst_dt, std::abs(dcdt[k] - ref.dcdt(i)));
    }
  }
  CHECK(worst < 1e-12);
  CHECK(worst_dt < 1e-6);  // the reference differentiates numerically
}

TEST_CASE("human contact kernel matches the golden-section reference", "[human]") {
  const HumanModel& m = human_model();
  Rng rng(15, 0);
  const int N = 40, n_items = 5;
  HumanBatch B(N);
  std::vector<double> items(static_cast<size_t>(N) * n_items * 6), radii(n_items);
  for (double& r : radii) r = rng.uniform(0.03, 0.09);
  std::vector<HumanFkResult> humans;
  for (int e = 0; e < N; ++e) {
    const HumanPose pose = half_range_pose(rng);
    humans.push_back(human_fk_reference(m, pose.data()));
    put_human(B, e, humans.back());
    for (int i = 0; i < n_items; ++i) {
      const Vector3d a = Vector3d(pose[0], pose[1], 1.0) + rand_vec(rng, 0.7);
      const Vector3d b = i == 0 ? a : Vector3d(a + rand_vec(rng, 0.2));  // item 0: a sphere
      for (int r = 0; r < 3; ++r) {
        items[(static_cast<size_t>(e) * n_items + i) * 6 + r] = a(r);
        items[(static_cast<size_t>(e) * n_items + i) * 6 + 3 + r] = b(r);
      }
    }
  }
  std::vector<uint8_t> contact(N, 9), contact2(N, 9);
  std::vector<double> dmin(N);
  human_contact_range(B, m.fk, items.data(), radii.data(), n_items, contact.data(), dmin.data(), 0, N);
  human_contact_range(B, m.fk, items.data(), radii.data(), n_items, contact2.data(), nullptr, 0, N);
  int hits = 0;
  for (int e = 0; e < N; ++e) {
    std::vector<RobotPart> parts;
    for (int i = 0; i < n_items; ++i) {
      const double* it = &items[(static_cast<size_t>(e) * n_items + i) * 6];
      parts.push_back({Vector3d(it), Vector3d(it + 3), radii[static_cast<size_t>(i)]});
    }
    const double ref = human_min_distance_reference(m, humans[static_cast<size_t>(e)], parts);
    CHECK(std::abs(dmin[e] - ref) < 1e-8);
    for (const RobotPart& part : parts) {  // one segment at a time (the moving field's ground truth)
      const double one = human_min_distance_reference(m, humans[static_cast<size_t>(e)], {part});
      const double d = human_segment_distance(m.fk, &B.cap[static_cast<size_t>(e) * kHumanCapsules * 6], part.a.data(),
                                              part.b.data());
      CHECK(std::abs(d - part.radius - one) < 1e-8);
    }
    CHECK(contact[e] == (ref < 0.0 ? 1 : 0));
    CHECK(contact2[e] == contact[e]);
    hits += contact[e];
  }
  CHECK(hits > 5);
  CHECK(hits < N - 5);
}

TEST_CASE("human rows: J_x xdot is the time derivative of the rows along replayed motion, robot still", "[human]") {
  const HumanModel& m = human_model();
  const HumanMotionLibrary lib = load_default_human_motion();
  const TiagoArmModel arm = load_tiago_arm_model(0.3);
  // The reference's HRI start: torso 0.3, right arm [0, 0, pi/2, pi/2, pi/2, 0, 0].
  ArmQ q;
  q << 0.0, 0.0, 1.5707963267948966, 1.5707963267948966, 1.5707963267948966, 0.0, 0.0;
  const ArmFkResult afk = arm_fk_reference(arm, q);
  const int P = kArmPoi, nq = kArmJoints;
  std::vector<double> delta(P);
  for (int i = 0; i < P; ++i) delta[static_cast<size_t>(i)] = arm.poi[static_cast<size_t>(i)].radius + 0.05;
  const HumanRowsConst rows = make_human_rows(delta, nq, 0.02);
  // Times: every 7th frame of the test split, at fractional offsets; the
  // robot is placed 1 m closer along x so that the human comes within reach.
  HumanReplayConfig replay;
  replay.split = HumanSplit::Test;
  const double dt = 1.0 / 30.0, h = 5e-4;  // h in env seconds (0.015 frames at real time)
  int lo = 0, hi = 0;
  lib.split_range(HumanSplit::Test, lo, hi);
  std::vector<double> ts;
  for (int f = lo + 2; f < hi - 3; f += 7) ts.push_back(f + 0.37);
  const int N = static_cast<int>(ts.size());
  std::vector<double> poi(static_cast<size_t>(N) * P * 3), J(static_cast<size_t>(N) * P * 3 * nq);
  for (int e = 0; e < N; ++e)
    for (int i = 0; i < P; ++i)
      for (int r = 0; r < 3; ++r) {
        poi[(static_cast<size_t>(e) * P + i) * 3 + r] = afk.poi[static_cast<size_t>(i)](r) + (r == 0 ? 0.6 : 0.0);
        for (int j = 0; j < nq; ++j)
          J[((static_cast<size_t>(e) * P + i) * 3 + r) * nq + j] = afk.J_poi[static_cast<size_t>(i)](r, j);
      }
  auto rows_at = [&](double shift, std::vector<double>& c, std::vector<double>& dcdt, std::vector<double>& dex) {
    std::vector<double> t(ts);
    for (double& x : t) x += shift * replay.frames_per_step / dt;  // env seconds -> frames
    HumanBatch B(N);
    human_motion_range(lib, replay, dt, t.data(), B, 0, N);
    human_capsules_range(m.fk, B, 0, N);
    std::vector<double> Jq(static_cast<size_t>(N) * P * nq);
    c.assign(static_cast<size_t>(N) * P, 0.0);
    dcdt = dex = c;
    human_rows_range(rows, m.fk, B, poi.data(), J.data(), c.data(), Jq.data(), dcdt.data(), dex.data(), 0, N);
  };
  std::vector<double> c0, r0, x0, cp, rp, xp, cm, rm, xm;
  rows_at(0.0, c0, r0, x0);
  rows_at(h, cp, rp, xp);
  rows_at(-h, cm, rm, xm);
  double worst = 0, peak = 0;
  int near = 0;
  for (size_t k = 0; k < c0.size(); ++k) {
    if (x0[k] > 0.6) continue;  // only rows of points near the human carry a signal
    ++near;
    const double fd = (cp[k] - cm[k]) / (2 * h);
    worst = std::max(worst, std::abs(fd - r0[k]));
    peak = std::max(peak, std::abs(r0[k]));
  }
  INFO(near << " rows within 0.6 m, peak |dc/dt| " << peak << " m/s, worst mismatch " << worst);
  CHECK(near > 50);
  CHECK(peak > 0.05);
  CHECK(worst < 1e-4 * std::max(1.0, peak));
}

TEST_CASE("human rows fused with the arm's FK lanes equal the range kernel on the same inputs", "[human]") {
  // The path an env takes: pose lanes -> human_fk_lanes -> human_rows_lanes
  // on the arm's ArmFkLanes (PoIs and Jacobians), without going through memory.
  const HumanModel& m = human_model();
  const TiagoArmModel arm = load_tiago_arm_model(0.3);
  const lanes::ArmFkConst ak(arm);
  Rng rng(16, 0);
  const int N = lanes::kLanes, P = kArmPoi, nq = kArmJoints;
  HumanBatch B(N);
  lanes::vd q[kArmJoints];
  for (int e = 0; e < N; ++e) {
    HumanPose pose = half_range_pose(rng);
    pose[0] = rng.uniform(0.5, 0.9);
    const HumanPose rate = moderate_rate(rng);
    std::copy(pose.begin(), pose.end(), &B.pose[static_cast<size_t>(e) * kHumanPoseDim]);
    std::copy(rate.begin(), rate.end(), &B.pose_rate[static_cast<size_t>(e) * kHumanPoseDim]);
    for (int j = 0; j < kArmJoints; ++j) q[j][e] = rng.uniform(arm.lower[static_cast<size_t>(j)], arm.upper[static_cast<size_t>(j)]);
  }
  lanes::ArmFkLanes afk;
  lanes::arm_fk_lanes(ak, q, afk, true);
  const HumanRowsConst rows = make_human_rows(std::vector<double>(P, 0.1), nq, 0.02);
  lanes::vd pose[kHumanPoseDim], rate[kHumanPoseDim];
  lanes::human_load_pose_lanes(B, 0, N, pose, rate);
  lanes::HumanCapsLanes h;
  lanes::human_fk_lanes(m.fk, pose, rate, h);
  lanes::vd c[kArmPoi], J[kArmPoi][kArmJoints], dcdt[kArmPoi], dex[kArmPoi];
  lanes::human_rows_lanes<kArmJoints>(rows, m.fk, afk.poi, afk.Jp, h, c, J, dcdt, dex);
  // The same through memory.
  human_capsules_range(m.fk, B, 0, N);
  std::vector<double> poi(static_cast<size_t>(N) * P * 3), Jp(static_cast<size_t>(N) * P * 3 * nq);
  for (int e = 0; e < N; ++e)
    for (int i = 0; i < P; ++i)
      for (int r = 0; r < 3; ++r) {
        poi[(static_cast<size_t>(e) * P + i) * 3 + r] = afk.poi[i][r][e];
        for (int j = 0; j < nq; ++j) Jp[((static_cast<size_t>(e) * P + i) * 3 + r) * nq + j] = afk.Jp[i][r][j][e];
      }
  std::vector<double> c2(static_cast<size_t>(N) * P), J2(static_cast<size_t>(N) * P * nq), d2(c2), x2(c2);
  human_rows_range(rows, m.fk, B, poi.data(), Jp.data(), c2.data(), J2.data(), d2.data(), x2.data(), 0, N);
  int near = 0;
  for (int e = 0; e < N; ++e)
    for (int i = 0; i < P; ++i) {
      const size_t k = static_cast<size_t>(e) * P + i;
      CHECK(c[i][e] == c2[k]);
      CHECK(dcdt[i][e] == d2[k]);
      CHECK(dex[i][e] == x2[k]);
      for (int j = 0; j < nq; ++j) CHECK(J[i][j][e] == J2[k * nq + j]);
      near += x2[k] < 0.5;
    }
  CHECK(near > 5);
}
