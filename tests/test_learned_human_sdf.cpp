// The learned (pose-conditioned) human field: the pose gradient of the fused
// backward and the lane kernel's grad_p d and dd/dt against central finite
// differences; the human training data's labels against the env's rows;
// the shipped model in HRI against the analytic rows; bad settings; and
// random-alpha ATACOM with the learned human counted against the analytic
// rows and the exact contact check.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "atacom/safe_env.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "kernels/human_rows_lanes.hpp"
#include "kernels/redsdf_human_lanes.hpp"
#include "train/sdf_human_data.hpp"
#include "tests/near.hpp"

using namespace atacom;

namespace {

std::shared_ptr<LearnedHuman> random_human_field() {
  RedsdfArch a;
  a.pose_dim = kHumanDofs;
  a.hidden = {32, 32, 24};
  a.trunk_layers = 2;
  a.side_width = 8;
  a.centre = {0.0, 0.05, 0.9};
  auto m = std::make_shared<RedsdfModel>(a);
  init_redsdf(*m, 3);
  const RedsdfLayer& s = m->layout.side[1];
  m->params[s.b] = 1.0f;  // rho and alpha in the blend's steep region
  m->params[s.b + 1] = 0.2f;
  auto o = std::make_shared<LearnedHuman>();
  o->model = m;
  o->batch = std::make_shared<RedsdfBatch>(*m);
  return o;
}

// The learned human's margin as the env applied it (model manifest).
double le_margin_of(const ArmEnv& env) { return load_arm_learned_human(env.config().sdf)->margin; }

}  // namespace

TEST_CASE("redsdf batch: the pose gradient of the fused backward matches central finite differences", "[redsdf]") {
  auto o = random_human_field();
  const int n = 40, P = kHumanDofs;
  Rng rng(5, 0);
  std::vector<float> p(3 * n), q(size_t(P) * n), d(n), g(3 * n), gq(size_t(P) * n), g_plain(3 * n);
  for (float& x : p) x = float(rng.uniform(-1.0, 1.5));
  for (float& x : q) x = float(rng.uniform(-1.0, 1.0));
  o->batch->evaluate_range(p.data(), q.data(), false, 0, n, d.data(), g.data(), gq.data());
  std::vector<float> d2(n);
  o->batch->evaluate_range(p.data(), q.data(), false, 0, n, d2.data(), g_plain.data());
  CHECK(d2 == d);
  for (int i = 0; i < 3 * n; ++i) CHECK(std::abs(g_plain[size_t(i)] - g[size_t(i)]) < 1e-5);  // the same grad_p either way
  int bad = 0, total = 0, kinked = 0;
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < P; ++k) {
      const Eigen::Vector3d pi(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
      auto fd = [&](double h) {
        std::vector<double> pose(q.begin() + i * P, q.begin() + (i + 1) * P);
        pose[size_t(k)] += h;
        const double dp = redsdf_reference(*o->model, pi, pose.data());
        pose[size_t(k)] -= 2 * h;
        return (dp - redsdf_reference(*o->model, pi, pose.data())) / (2 * h);
      };
      // Two step sizes that disagree: a ReLU kink inside the stencil (the derivative jumps there).
      const double f1 = fd(1e-3), f2 = fd(2.5e-4);
      if (!near_abs_rel(f1, f2, 1e-5, 1e-3)) { ++kinked; continue; }
      ++total;
      const bool off = !near_abs_rel(f2, gq[size_t(i * P + k)], 1e-4, 2e-3);
      if (off && bad < 8) WARN("point " << i << " pose " << k << " fd " << f2 << " kernel " << gq[size_t(i * P + k)]);
      bad += off;
    }
  INFO(bad << " of " << total << " pose derivatives off, " << kinked << " skipped at kinks");
  CHECK(bad == 0);
  CHECK(kinked < total / 10);
}

TEST_CASE("learned human lanes: grad_p d and dd/dt (root and joint motion) match central finite differences", "[redsdf][hri]") {
  auto o = random_human_field();
  constexpr int L = lanes::kLanes, npoi = 5;
  Rng rng(9, 0);
  std::vector<double> pose(size_t(L) * kHumanPoseDim), rate(pose.size());
  for (int l = 0; l < L; ++l) {
    double* x = &pose[size_t(l) * kHumanPoseDim];
    double* v = &rate[size_t(l) * kHumanPoseDim];
    x[0] = rng.uniform(0.5, 1.5), x[1] = rng.uniform(-1, 1), x[2] = rng.uniform(-0.05, 0.05), x[3] = rng.uniform(-3, 3);
    for (int k = 0; k < kHumanPoseDim; ++k) v[k] = rng.uniform(-1.5, 1.5);
    for (int k = kHumanRootDofs; k < kHumanPoseDim; ++k) x[k] = rng.uniform(-0.8, 0.8);
  }
  lanes::vd poi[npoi][3];
  for (int i = 0; i < npoi; ++i)
    for (int r = 0; r < 3; ++r)
      for (int l = 0; l < L; ++l) poi[i][r][l] = pose[size_t(l) * kHumanPoseDim + size_t(r)] + rng.uniform(-0.8, 0.8) + (r == 2 ? 0.9 : 0.0);
  lanes::vd d[npoi], g[npoi][3], ddt[npoi];
  learned_human_distance_lanes(*o, pose.data(), rate.data(), L, poi, npoi, d, g, ddt);
  const double h = 1e-3;
  int bad = 0, total = 0;
  // grad_p: move the points.
  for (int r = 0; r < 3; ++r) {
    lanes::vd pp[npoi][3], pm[npoi][3], dp[npoi], dm[npoi], gd[npoi][3], td[npoi];
    for (int i = 0; i < npoi; ++i)
      for (int c = 0; c < 3; ++c) pp[i][c] = pm[i][c] = poi[i][c];
    for (int i = 0; i < npoi; ++i) pp[i][r] += h, pm[i][r] -= h;
    learned_human_distance_lanes(*o, pose.data(), rate.data(), L, pp, npoi, dp, gd, td);
    learned_human_distance_lanes(*o, pose.data(), rate.data(), L, pm, npoi, dm, gd, td);
    for (int i = 0; i < npoi; ++i)
      for (int l = 0; l < L; ++l) {
        ++total;
        bad += !near_abs_rel((dp[i][l] - dm[i][l]) / (2 * h), g[i][r][l], 2e-3, 1e-2);
      }
  }
  // dd/dt at fixed p: move the whole pose (root included) along its rate.
  std::vector<double> xp(pose), xm(pose);
  for (size_t k = 0; k < pose.size(); ++k) xp[k] += h * rate[k], xm[k] -= h * rate[k];
  lanes::vd dp[npoi], dm[npoi], gd[npoi][3], td[npoi];
  learned_human_distance_lanes(*o, xp.data(), rate.data(), L, poi, npoi, dp, gd, td);
  learned_human_distance_lanes(*o, xm.data(), rate.data(), L, poi, npoi, dm, gd, td);
  int bad_t = 0;
  double peak = 0;
  for (int i = 0; i < npoi; ++i)
    for (int l = 0; l < L; ++l) {
      peak = std::max(peak, std::abs(ddt[i][l]));
      bad_t += !near_abs_rel((dp[i][l] - dm[i][l]) / (2 * h), ddt[i][l], 3e-3, 2e-2);
    }
  INFO(bad << " of " << total << " gradient entries off, " << bad_t << " of " << npoi * L << " rates off, peak " << peak);
  CHECK(bad <= total / 50);
  CHECK(bad_t <= npoi * L / 20);
  CHECK(peak > 0.1);
}

TEST_CASE("human SDF data: labels are the env rows' smooth min, surface points sit on the capsules", "[redsdf][hri]") {
  const HumanModel model = load_human_model();
  const HumanMotionLibrary lib = load_default_human_motion();
  SdfDataConfig c = default_sdf_data_config();
  c.poses = 6;
  c.surface_points = 40;
  c.epsilons = {0.0, 0.05, -0.01};
  const SdfSamples s = make_human_sdf_samples(model, lib, c);
  REQUIRE(s.pose_dim == kHumanDofs);
  REQUIRE(int(s.poses.size()) == 6 * kHumanDofs);
  REQUIRE(int(s.pose_id.size()) == s.n);
  int lo = 0, hi = 0;
  lib.split_range(HumanSplit::Train, lo, hi);
  // Every pose is a frame of the training split.
  for (int pi = 0; pi < 6; ++pi) {
    bool found = false;
    for (int f = lo; f < hi && !found; ++f)
      found = std::equal(s.poses.begin() + pi * kHumanDofs, s.poses.begin() + (pi + 1) * kHumanDofs,
                         lib.frames.begin() + size_t(f) * kHumanPoseDim + kHumanRootDofs);
    CHECK(found);
  }
  // The first 3 samples of each surface point: offsets 0, 5 cm, -1 cm along the normal.
  double cap[kHumanCapsules * 6];
  human_body_capsules(model, &s.poses[0], cap);
  for (int i = 0; i < 40 * 3; i += 3) {
    double de = 0;
    const double p0[3] = {s.p[3 * i], s.p[3 * i + 1], s.p[3 * i + 2]};
    human_body_distance(model, cap, 0.0, p0, nullptr, &de);
    CHECK(std::abs(de) < 1e-5);  // on the surface (float storage)
    const double y = human_body_distance(model, cap, kHumanSdfDefaultBlend, p0, nullptr);
    CHECK(std::abs(y - s.y[size_t(i)]) < 1e-6);
    CHECK(s.y[size_t(i)] <= de + 1e-6);  // the smooth min never exceeds the exact one
  }
}

TEST_CASE("hri with the shipped learned human: rows agree with the analytic rows, bad settings name the key", "[redsdf][hri]") {
  const int N = 64;
  ArmEnvConfig ca = default_arm_env_config(ArmTask::Hri);
  ca.sdf = {{"human", "analytic"}, {"table", "analytic"}, {"tiago", "analytic"}};
  ArmEnvConfig cl = ca;
  cl.sdf = {{"human", "learned"}};
  ArmEnv an(ca, N), le(cl, N);
  an.seed(4), le.seed(4);
  an.reset(), le.reset();
  for (int e = 0; e < N; ++e) {
    le.set_human_time(e, an.human_time()[size_t(e)]);
    le.set_state(e, &an.q()[size_t(e) * kArmJoints], &an.goal()[size_t(e) * 3]);
  }
  ProjectorBatch pa(an.projector_model(), N), pl(le.projector_model(), N);
  an.constraint_model(pa, 0, N);
  le.constraint_model(pl, 0, N);
  const int k = an.spec().num_constraints;
  const double margin = le.human_rows().delta[0] - an.human_rows().delta[0];
  CHECK(margin > 0.0);
  CHECK(margin < 0.1);
  double worst = 0;
  int near = 0;
  for (int e = 0; e < N; ++e)
    for (int i = 0; i < kArmPoi; ++i) {
      const int r = kRowHuman + i;
      const double da = an.human_rows().delta[i] - pa.c[size_t(e * k + r)];
      const double dl = le.human_rows().delta[i] - pl.c[size_t(e * k + r)];
      if (da > 0.5) continue;
      ++near;
      worst = std::max(worst, std::abs(dl - da));
      CHECK(dl - da <= margin);  // the learned rows never claim more room than the margin covers
    }
  INFO(near << " PoIs within 0.5 m of the human, worst |d_learned - d_analytic| " << worst << ", margin " << margin);
  CHECK(near > 10);
  CHECK(worst < 0.06);
  // Settings.
  CHECK(sdf_flag_override("hri", "learned") ==
        nlohmann::json{{"sdf", {{"human", "learned"}, {"table", "learned"}, {"tiago", "learned"}}}});
  ArmEnvConfig bad = ca;
  bad.sdf = {{"human", "learned:data/sdf/table"}};
  CHECK_THROWS_WITH(ArmEnv(bad, 1), Catch::Contains("holds object 'table', expected 'human'"));
  bad.sdf = {{"human", "lerned"}};
  CHECK_THROWS_WITH(ArmEnv(bad, 1), Catch::Contains("env.sdf.human"));
  ArmEnvConfig table = default_arm_env_config(ArmTask::Table);
  table.sdf = {{"human", "learned"}};
  CHECK_THROWS_WITH(ArmEnv(table, 1), Catch::Contains("env.sdf.human"));
}

TEST_CASE("hri with the learned human: identical for 1 and 2 threads", "[redsdf][hri]") {
  std::vector<double> c[2];
  for (int threads : {1, 2}) {
    set_num_threads(threads);
    auto env = make_env({"hri", 24, SafetyLayer::Atacom, sdf_flag_override("hri", "learned")});
    env->seed(8);
    env->reset();
    Rng rng(2, 0);
    std::vector<double> a(size_t(24) * kArmJoints);
    for (int t = 0; t < 30; ++t) {
      for (double& x : a) x = rng.uniform(-1.0, 1.0);
      env->step(a.data());
    }
    c[threads - 1] = env->buffers().constraints;
  }
  set_num_threads(0);
  CHECK(c[0] == c[1]);
}

// The learned rows keep the analytic ones: with thresholds delta + margin
// and learned - analytic <= margin near the human, a learned row within its
// tolerance implies the analytic row within the same tolerance. Counted here
// along random-alpha ATACOM rollouts with the learned human on both motion
// splits, against the analytic rows (the env's smooth min over the capsules)
// and the exact contact check; the analytic-field run of the same seeds is
// the reference for the contact count (issue 11: within 2x).
TEST_CASE("hri random-alpha ATACOM with the learned human: analytic rows within tolerance, contacts within 2x analytic",
          "[redsdf][hri][slow]") {
  const int N = 256, steps = 500;
  long contacts[2] = {0, 0}, checked = 0, over_feasible = 0, over_any = 0;
  double worst = -INFINITY;
  for (int learned = 0; learned < 2; ++learned)
    for (const char* split : {"train", "test"}) {
      nlohmann::json cfg = sdf_flag_override("hri", learned ? "learned" : "analytic");
      cfg["hri"] = {{"split", split}};
      auto env = make_env({"hri", N, SafetyLayer::Atacom, cfg});
      env->seed(21);
      const auto& arm = dynamic_cast<const ArmEnv&>(dynamic_cast<SafeEnv&>(*env).inner());
      const EnvSpec& s = env->spec();
      const int ni = int(s.info_names.size());
      auto col = [&](const char* name) {
        return int(std::find(s.info_names.begin(), s.info_names.end(), name) - s.info_names.begin());
      };
      const int col_h = col("human_collision"), col_b = col("atacom_bias_out");
      const double margin = learned ? le_margin_of(arm) : 0.0;
      const HumanFkConst& hk = arm.human_model().fk;
      Rng rng(31, 0);
      std::vector<double> a(size_t(N) * kArmJoints);
      for (int t = 0; t < steps; ++t) {
        for (double& x : a) x = rng.uniform(-1.0, 1.0);
        env->step(a.data());
        const EnvBuffers& b = env->buffers();
        for (int e = 0; e < N; ++e) {
          const float* info = &b.info[size_t(e) * ni];
          contacts[learned] += info[col_h] > 0;
          if (!learned || b.done(e)) continue;  // after a reset q is the new episode's
          const ArmFkResult fk = arm_fk_reference(arm.model(), Eigen::Map<const ArmQ>(&arm.q()[size_t(e) * kArmJoints]));
          const double* cap = &arm.humans().cap[size_t(e) * kHumanCapsules * 6];
          double A[kHumanCapsules][3], B[kHumanCapsules][3], V[kHumanCapsules][3] = {};
          for (int c = 0; c < kHumanCapsules; ++c)
            for (int r = 0; r < 3; ++r) A[c][r] = cap[c * 6 + r], B[c][r] = cap[c * 6 + 3 + r];
          bool row_over = false;
          for (int i = 0; i < kArmPoi; ++i) {
            double g[3], ddt, dex;
            const double d = human_impl::human_point_distance<double>(A, B, V, V, hk.cap_inv_len2, hk.cap_radius,
                                                                      arm.config().hri.human_blend,
                                                                      fk.poi[size_t(i)].data(), g, ddt, dex);
            const double c_analytic = (arm.human_rows().delta[i] - margin) - d;
            const double excess = c_analytic - s.constraint_tolerance[size_t(kRowHuman + i)];
            worst = std::max(worst, excess);
            row_over = row_over || excess > 0;
            ++checked;
          }
          over_any += row_over;
          over_feasible += row_over && !(info[col_b] > 0);
        }
      }
    }
  INFO("contacts analytic " << contacts[0] << " learned " << contacts[1] << "; " << checked
                            << " analytic rows checked, worst row minus tolerance " << worst << ", steps over "
                            << over_any << " (feasible " << over_feasible << ")");
  CHECK(checked > 100000);
  CHECK(over_feasible == 0);
  CHECK(contacts[1] <= 2 * contacts[0] + 1);  // +1: both counts are near zero
  WARN("contacts analytic " << contacts[0] << " learned " << contacts[1] << ", worst analytic row minus tolerance " << worst
                              << ", learned steps with an analytic row over tolerance " << over_any << " (feasible "
                              << over_feasible << ") of " << checked / kArmPoi);
}
