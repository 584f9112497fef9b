// HRI-Sim ("hri"): the cup-upright row and every row's J_q against finite
// differences, J_x xdot against the finite-difference time derivative of the
// rows along replayed held-out motion, the batched step against the scalar
// reference, thread-count independence, snapshot/restore, and random alpha
// through ATACOM on held-out motion against the same actions without it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/trainer.hpp"
#include "envs/arm/arm_env.hpp"
#include "src/core/binary_io.hpp"

using namespace atacom;

namespace {

ArmEnvConfig hri_config(HumanSplit split = HumanSplit::Train) {
  ArmEnvConfig c = default_arm_env_config(ArmTask::Hri);
  c.hri.split = split;
  return c;
}

std::vector<double> random_actions(Rng& rng, int N, double scale = 1.0) {
  std::vector<double> a(static_cast<size_t>(N) * kArmJoints);
  for (double& x : a) x = scale * rng.uniform(-1.0, 1.0);
  return a;
}

HumanFkResult human_of(const ArmEnv& env, int e) {
  const HumanBatch& h = env.humans();
  return human_fk_reference(env.human_model(), &h.pose[size_t(e) * kHumanPoseDim], &h.pose_rate[size_t(e) * kHumanPoseDim]);
}

uint64_t state_hash(const ArmEnv& env) {
  const EnvBuffers& b = env.buffers();
  uint64_t h = bin::fnv1a(nullptr, 0);
  h = bin::fnv1a(env.q().data(), env.q().size() * sizeof(double), h);
  h = bin::fnv1a(env.human_time().data(), env.human_time().size() * sizeof(double), h);
  h = bin::fnv1a(b.obs.data(), b.obs.size() * sizeof(float), h);
  h = bin::fnv1a(b.reward.data(), b.reward.size() * sizeof(float), h);
  h = bin::fnv1a(b.constraints.data(), b.constraints.size() * sizeof(double), h);
  h = bin::fnv1a(b.terminated.data(), b.terminated.size(), h);
  h = bin::fnv1a(b.info.data(), b.info.size() * sizeof(float), h);
  return h;
}

}  // namespace

TEST_CASE("hri: 44 rows from the groups, p = 1, metrics in info, 512-512-256 SAC defaults", "[hri][fast]") {
  ArmEnv env(hri_config(), 3);
  const EnvSpec& s = env.spec();
  CHECK(s.name == "hri");
  CHECK(s.num_constraints == kArmMaxRows);
  CHECK(s.obs_dim == kHriObsDim);
  CHECK(s.horizon == 500);
  CHECK(std::abs(s.dt - 1.0 / 30.0) < 1e-15);
  CHECK(s.constraint_names[kRowHuman] == "human_" + env.model().poi[0].name);
  CHECK(s.constraint_names[kRowUpright] == "cup_upright");
  const ProjectorModel pm = env.projector_model();
  CHECK(pm.k == 44);
  CHECK(pm.p == 1);
  for (const char* name : {"collision", "human_collision", "spill", "min_human_distance", "final_distance"})
    CHECK(std::find(s.info_names.begin(), s.info_names.end(), name) != s.info_names.end());
  CHECK(env.config().hri.spill_angle > env.config().hri.theta_max);
  // The paper preset's networks for HRI (configs/presets/paper.json, reference 5.2).
  const nlohmann::json sac = resolve_run_config({{"train", {{"env", "hri"}, {"algo", "atacom-sac"}}}}).learner;
  CHECK(sac.at("actor").at("hidden") == nlohmann::json({512, 512, 256}));
  CHECK(sac.at("critic").at("hidden") == nlohmann::json({512, 512, 256}));
  // JSON round trip, and the hri section is rejected where it does not belong.
  const nlohmann::json j = default_arm_env_config(ArmTask::Hri);
  ArmEnvConfig back = default_arm_env_config(ArmTask::Hri);
  from_json(j, back);
  CHECK(nlohmann::json(back) == j);
  nlohmann::json bad = j;
  bad["hri"]["spill_angle"] = 0.1;
  CHECK_THROWS_WITH(from_json(bad, back), Catch::Contains("spill_angle"));
  ArmEnvConfig table = default_arm_env_config(ArmTask::Table);
  nlohmann::json tj = table;
  CHECK(!tj.contains("hri"));
  tj["hri"] = j["hri"];
  CHECK_THROWS(from_json(tj, table));
}

TEST_CASE("hri: every row's J_q, the upright row's included, matches central finite differences", "[hri][fast]") {
  ArmEnv env(hri_config(), 4);
  env.seed(5);
  Rng rng(6, 0);
  const double h = 1e-6;
  int tested = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const int e = trial % 4;
    const HumanFkResult human = human_of(env, e);
    std::array<double, kArmJoints> q;
    for (int j = 0; j < kArmJoints; ++j) q[j] = rng.uniform(env.model().lower[j], env.model().upper[j]);
    const ArmEval ev = env.evaluate_reference(q.data(), &human);
    for (int j = 0; j < kArmJoints; ++j) {
      auto qp = q, qm = q;
      qp[j] += h;
      qm[j] -= h;
      const ArmEval ep = env.evaluate_reference(qp.data(), &human), em = env.evaluate_reference(qm.data(), &human);
      for (int r = kRowHuman; r < kArmMaxRows; ++r) {
        const double fd = (ep.c(r) - em.c(r)) / (2 * h);
        // Smooth rows: 1e-5; a kink of the smooth min's clamp can sit between the probes.
        if (std::abs(fd - ev.J(r, j)) > 1e-5 && r != kRowUpright) continue;
        CHECK(std::abs(fd - ev.J(r, j)) < 1e-5);
        ++tested;
      }
    }
    // The upright row is exact: cos(theta_max - margin) - cos(tilt).
    CHECK(std::abs(ev.c(kRowUpright) - (std::cos(env.config().hri.theta_max - env.config().hri.upright.margin[0]) -
                                        std::cos(ev.tilt))) < 1e-12);
  }
  CHECK(tested > 60 * kArmJoints * 10 * 95 / 100);
}

TEST_CASE("hri: J_x xdot equals the finite-difference time derivative of the rows along replayed held-out motion",
          "[hri][fast]") {
  const int N = 8;
  ArmEnv env(hri_config(HumanSplit::Test), N);
  env.seed(11);
  ProjectorBatch pb(env.projector_model(), N);
  const double fps = env.config().hri.frames_per_step;
  const double sec_per_frame = env.config().dt / fps;
  const double d = 1e-4;  // frames
  double worst = 0.0, peak = 0.0;
  int checked = 0;
  for (int e = 0; e < N; ++e) {
    const double t0 = env.human_time()[size_t(e)];
    for (int s = 0; s < 120; ++s) {
      const double t = t0 + 0.37 * s;  // along the episode's replay, off the frame grid
      env.set_human_time(e, t + d);
      env.constraint_model(pb, e, e + 1);
      std::vector<double> c_plus(pb.c.begin() + e * 44, pb.c.begin() + (e + 1) * 44);
      env.set_human_time(e, t - d);
      env.constraint_model(pb, e, e + 1);
      std::vector<double> c_minus(pb.c.begin() + e * 44, pb.c.begin() + (e + 1) * 44);
      env.set_human_time(e, t);
      env.constraint_model(pb, e, e + 1);
      CHECK(pb.xdot[size_t(e)] == 1.0);
      for (int r = 0; r < 44; ++r) {
        const double fd = (c_plus[size_t(r)] - c_minus[size_t(r)]) / (2 * d * sec_per_frame);
        const double jx = pb.Jx[size_t(e) * 44 + r] * pb.xdot[size_t(e)];
        if (r < kRowHuman || r == kRowUpright) {
          CHECK(jx == 0.0);
          CHECK(std::abs(fd) < 1e-9);  // the robot holds still: only the human's rows move
          continue;
        }
        worst = std::max(worst, std::abs(fd - jx));
        peak = std::max(peak, std::abs(jx));
        ++checked;
      }
    }
  }
  INFO("worst mismatch " << worst << " peak |dc/dt| " << peak);
  CHECK(checked == N * 120 * kArmPoi);
  CHECK(peak > 0.1);       // the human does move towards and away from the arm
  CHECK(worst < 1e-4);     // m/s
}

TEST_CASE("hri: batched step equals the per-env scalar reference (rows, J_q, J_x, contact, cup)", "[hri][fast]") {
  const int N = 37;
  ArmEnv env(hri_config(), N);
  env.seed(3);
  Rng rng(4, 0);
  ProjectorBatch pb(env.projector_model(), N);
  const int K = kArmMaxRows;
  int checked = 0, ends = 0;
  for (int s = 0; s < 60; ++s) {
    const auto a = random_actions(rng, N);
    env.step(a.data());
    env.constraint_model(pb, 0, N);
    const EnvBuffers& b = env.buffers();
    for (int e = 0; e < N; ++e) {
      const HumanFkResult human = human_of(env, e);
      const ArmEval now = env.evaluate_reference(&env.q()[size_t(e) * kArmJoints], &human);
      if (b.done(e)) {  // autoreset: the new episode starts clear of every row, the human's included
        CHECK(now.c.maxCoeff() <= -env.config().init_margin);
        CHECK(!now.collision);
        ++ends;
        continue;
      }
      for (int r = 0; r < K; ++r) {
        CHECK(std::abs(pb.c[size_t(e) * K + r] - now.c(r)) < 1e-9);
        for (int j = 0; j < kArmJoints; ++j) CHECK(std::abs(pb.Jq[(size_t(e) * K + r) * kArmJoints + j] - now.J(r, j)) < 1e-9);
        CHECK(std::abs(pb.Jx[size_t(e) * K + r] - now.dcdt(r)) < 1e-5);  // reference: central differences
      }
      for (int r = 0; r < 3; ++r) CHECK(std::abs(b.obs[size_t(e) * kHriObsDim + 16 + r] - now.cup_axis(r)) < 1e-6);
      CHECK(std::abs(b.info[size_t(e) * b.info.size() / N + 11] - now.tilt) < 1e-5);
      ++checked;
    }
  }
  CHECK(checked > 1000);
  CHECK(ends > 0);
}

TEST_CASE("hri: identical for 1 and 2 threads, snapshot and restore re-step bitwise", "[hri][fast]") {
  const int N = 300;  // two parallel blocks, a partial lane group
  uint64_t h[2];
  for (int t = 0; t < 2; ++t) {
    set_num_threads(t + 1);
    ArmEnv env(hri_config(), N);
    env.seed(42);
    Rng rng(43, 0);
    for (int s = 0; s < 40; ++s) env.step(random_actions(rng, N).data());
    h[t] = state_hash(env);
  }
  set_num_threads(0);
  CHECK(h[0] == h[1]);

  ArmEnv env(hri_config(), 20);
  env.seed(8);
  Rng rng(9, 0);
  for (int s = 0; s < 30; ++s) env.step(random_actions(rng, 20).data());
  std::stringstream snap;
  env.save_state(snap);
  const Rng saved = rng;
  for (int s = 0; s < 40; ++s) env.step(random_actions(rng, 20).data());
  const uint64_t h1 = state_hash(env);
  ArmEnv other(hri_config(), 20);
  other.seed(1234);
  other.load_state(snap);
  rng = saved;
  for (int s = 0; s < 40; ++s) other.step(random_actions(rng, 20).data());
  CHECK(state_hash(other) == h1);
}

// The safety claim on motion the policy never trains on: the same random
// alpha streams with and without ATACOM.
TEST_CASE("hri: random alpha through ATACOM on held-out motion: 20x fewer human collisions, no static collision",
          "[hri][fast]") {
  const nlohmann::json cfg = {{"hri", {{"split", "test"}}}};
  const int N = 512, steps = 1000;  // two episodes per env with ATACOM
  long human[2] = {0, 0}, other[2] = {0, 0};
  double max_excess = -INFINITY;
  for (int on = 0; on < 2; ++on) {
    auto env = make_env({"hri", N, on ? SafetyLayer::Atacom : SafetyLayer::None, cfg});
    env->seed(3);
    const EnvSpec& s = env->spec();
    const int ni = int(s.info_names.size());
    const int col_h = int(std::find(s.info_names.begin(), s.info_names.end(), "human_collision") - s.info_names.begin());
    const int col_c = int(std::find(s.info_names.begin(), s.info_names.end(), "collision") - s.info_names.begin());
    Rng rng(17, 0);
    for (int t = 0; t < steps; ++t) {
      env->step(random_actions(rng, N).data());
      const EnvBuffers& b = env->buffers();
      for (int i = 0; i < N; ++i) {
        const float hc = b.info[size_t(i) * ni + col_h], cc = b.info[size_t(i) * ni + col_c];
        human[on] += hc > 0;
        other[on] += cc > 0 && !(hc > 0);
        if (on)
          for (int r = 0; r < s.num_constraints; ++r)
            max_excess = std::max(max_excess, b.constraints[size_t(i) * s.num_constraints + r] - s.constraint_tolerance[size_t(r)]);
      }
    }
  }
  INFO("human collisions off " << human[0] << " on " << human[1] << "; static off " << other[0] << " on " << other[1]
                               << "; worst row minus tolerance " << max_excess);
  CHECK(human[0] >= 20);
  CHECK(20 * human[1] <= human[0]);
  CHECK(other[1] == 0);
  CHECK(max_excess <= 0.0);
}

// The person does not avoid the robot and can corner the arm against a
// joint limit with the cup upright: then no action inside the box corrects
// every row (the projector reports atacom_bias_out) and a human row can leave
// its tolerance. Measured: 1 human contact in 768k training-motion steps
// (seeds 5-7), none on held-out motion; never a static collision or a spill.
TEST_CASE("hri: 1.5M steps of random alpha through ATACOM on both motion splits: rows leave tolerance only when infeasible",
          "[hri][slow]") {
  long human_total = 0;
  for (const char* split : {"train", "test"})
    for (uint64_t seed : {5u, 6u, 7u}) {
      const int N = 512, steps = 500;
      auto env = make_env({"hri", N, SafetyLayer::Atacom, {{"hri", {{"split", split}}}}});
      env->seed(seed);
      const EnvSpec& s = env->spec();
      const int ni = int(s.info_names.size());
      auto col = [&](const char* name) {
        return int(std::find(s.info_names.begin(), s.info_names.end(), name) - s.info_names.begin());
      };
      const int col_c = col("collision"), col_h = col("human_collision"), col_s = col("spill"), col_b = col("atacom_bias_out");
      Rng rng(seed + 100, 0);
      long static_hits = 0, human = 0, spills = 0, over_feasible = 0, over = 0;
      for (int t = 0; t < steps; ++t) {
        env->step(random_actions(rng, N).data());
        const EnvBuffers& b = env->buffers();
        for (int i = 0; i < N; ++i) {
          const float* info = &b.info[size_t(i) * ni];
          human += info[col_h] > 0;
          static_hits += info[col_c] > 0 && !(info[col_h] > 0);
          spills += info[col_s] > 0;
          bool row_over = false;
          for (int r = 0; r < s.num_constraints; ++r)
            row_over = row_over || b.constraints[size_t(i) * s.num_constraints + r] > s.constraint_tolerance[size_t(r)];
          over += row_over;
          over_feasible += row_over && !(info[col_b] > 0);
        }
      }
      INFO(split << " seed " << seed << ": human " << human << " static " << static_hits << " spills " << spills
                 << " steps over tolerance " << over << " (feasible " << over_feasible << ")");
      CHECK(static_hits == 0);
      CHECK(spills == 0);
      CHECK(over_feasible == 0);
      if (std::string(split) == "test") CHECK(human == 0);
      human_total += human;
    }
  CHECK(human_total <= 3);  // <= 1 per 512 episodes
}
