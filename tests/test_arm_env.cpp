// Manipulation envs: constraint rows against finite differences, the batched
// step against the scalar reference, "constraints imply no collision",
// determinism across thread counts, snapshot/restore, config handling.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <sstream>

#include "build_kind.hpp"
#include "envs/arm/arm_env.hpp"
#include "src/core/binary_io.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/trainer.hpp"
#include "train/sac.hpp"

using namespace atacom;

namespace {

const ArmTask kTasks[] = {ArmTask::Table, ArmTask::Shelf};

std::array<double, kArmJoints> random_q(const TiagoArmModel& m, Rng& rng, double margin = 0.0) {
  std::array<double, kArmJoints> q;
  for (int j = 0; j < kArmJoints; ++j) q[j] = rng.uniform(m.lower[j] + margin, m.upper[j] - margin);
  return q;
}

uint64_t state_hash(const ArmEnv& env) {
  const EnvBuffers& b = env.buffers();
  uint64_t h = atacom::bin::kFnv1aSeed;
  h = atacom::bin::fnv1a(env.q().data(), env.q().size() * sizeof(double), h);
  h = atacom::bin::fnv1a(env.goal().data(), env.goal().size() * sizeof(double), h);
  h = atacom::bin::fnv1a(b.obs.data(), b.obs.size() * sizeof(float), h);
  h = atacom::bin::fnv1a(b.reward.data(), b.reward.size() * sizeof(float), h);
  h = atacom::bin::fnv1a(b.constraints.data(), b.constraints.size() * sizeof(double), h);
  h = atacom::bin::fnv1a(b.terminated.data(), b.terminated.size(), h);
  h = atacom::bin::fnv1a(b.info.data(), b.info.size() * sizeof(float), h);
  return h;
}

std::vector<double> random_arm_actions(Rng& rng, int N) {
  std::vector<double> a(static_cast<size_t>(N) * kArmJoints);
  for (double& x : a) x = rng.uniform(-1.0, 1.0);
  return a;
}

}  // namespace

TEST_CASE("arm env config: JSON round trip and strict parsing", "[arm_env]") {
  for (ArmTask task : kTasks) {
    const ArmEnvConfig c = default_arm_env_config(task);
    nlohmann::json j = c;
    ArmEnvConfig back = default_arm_env_config(task);
    from_json(j, back);
    CHECK(nlohmann::json(back) == j);
    nlohmann::json bad = j;
    bad["reward"]["rho_x"] = 1.0;
    CHECK_THROWS_WITH(from_json(bad, back), Catch::Contains("rho_x"));
    bad = j;
    bad["constraints"]["obstacle"]["margin"] = {0.01, 0.02};
    CHECK_THROWS_WITH(from_json(bad, back), Catch::Contains("constraints.obstacle.margin"));
    bad = j;
    bad["constraints"]["body"]["tolerance"] = std::vector<double>(9, 0.5);  // above the margins: the guarantee would be lost
    CHECK_THROWS_WITH(from_json(bad, back), Catch::Contains("tolerance"));
    bad = j;
    bad["scene"]["yaw_deg"] = 45;
    CHECK_THROWS_WITH(from_json(bad, back), Catch::Contains("yaw_deg"));
    bad = j;
    bad["home"] = {-1.178, -1.178, -0.785, -0.392, -2.094, -1.413, -2.094};  // at the joint limits: not a safe start
    ArmEnvConfig unsafe = default_arm_env_config(task);
    from_json(bad, unsafe);
    CHECK_THROWS_WITH(ArmEnv(unsafe, 1), Catch::Contains("home"));
  }
}

TEST_CASE("arm constraint rows match finite differences, row by row", "[arm_env]") {
  for (ArmTask task : kTasks) {
    ArmEnv env(default_arm_env_config(task), 1);
    Rng rng(17, 0);
    const double h = 1e-6;
    int tested = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const auto q = random_q(env.model(), rng);
      const ArmEval ev = env.evaluate_reference(q.data());
      for (int j = 0; j < kArmJoints; ++j) {
        auto qp = q, qm = q;
        qp[j] += h;
        qm[j] -= h;
        const ArmEval ep = env.evaluate_reference(qp.data()), em = env.evaluate_reference(qm.data());
        for (int r = 0; r < kArmRows; ++r) {
          const double fd = (ep.c(r) - em.c(r)) / (2 * h);
          // Skip the rare samples that straddle a kink (inside a box, on the medial set).
          if (std::abs(fd - ev.J(r, j)) > 1e-5 && std::abs((ep.c(r) - ev.c(r)) / h - (ev.c(r) - em.c(r)) / h) > 1e-3)
            continue;
          INFO(env.spec().constraint_names[r] << " joint " << j);
          CHECK(std::abs(fd - ev.J(r, j)) < 1e-6);
          ++tested;
        }
      }
    }
    CHECK(tested > 300 * kArmJoints * kArmRows * 99 / 100);
  }
}

TEST_CASE("batched step equals the per-env scalar reference", "[arm_env]") {
  for (ArmTask task : kTasks) {
    const int N = 61;
    ArmEnv env(default_arm_env_config(task), N);
    env.seed(3);
    Rng rng(4, 0);
    ProjectorBatch pb(env.projector_model(), N);
    int checked = 0, collisions = 0;
    // Half the steps under the sanitizers (about 19,000 CHECKs a step): still collisions and resets.
    for (int s = 0; s < sanitizer_scaled(100, 2); ++s) {
      const auto a = random_arm_actions(rng, N);
      std::vector<double> q_before = env.q();
      env.step(a.data());
      env.constraint_model(pb, 0, N);
      for (int e = 0; e < N; ++e) {
        // Reconstruct the reached state from the pre-step state and the action.
        double q[kArmJoints];
        for (int j = 0; j < kArmJoints; ++j)
          q[j] = q_before[e * kArmJoints + j] + env.config().dt * env.vmax()[j] * a[e * kArmJoints + j];
        const ArmEval ev = env.evaluate_reference(q);
        const EnvBuffers& b = env.buffers();
        CHECK(bool(b.terminated[e]) == (ev.collision || ev.joint_violation));
        collisions += ev.collision;
        for (int r = 0; r < kArmRows; ++r) CHECK(std::abs(b.constraints[e * kArmRows + r] - ev.c(r)) < 1e-12);
        const double dist = (ev.grasp_p - Eigen::Map<const Eigen::Vector3d>(&env.goal()[e * 3])).norm();
        const bool dist_ok = std::abs(b.info[e * b.info.size() / N + 2] - dist) < 1e-5;
        CHECK((dist_ok || b.done(e)));
        if (!b.done(e)) {
          // The cached model the projector reads is the reached state's.
          const ArmEval now = env.evaluate_reference(&env.q()[e * kArmJoints]);
          for (int r = 0; r < kArmRows; ++r) {
            CHECK(std::abs(pb.c[e * kArmRows + r] - now.c(r)) < 1e-12);
            for (int j = 0; j < kArmJoints; ++j)
              CHECK(std::abs(pb.Jq[(e * kArmRows + r) * kArmJoints + j] - now.J(r, j)) < 1e-12);
          }
          for (int j = 0; j < kArmJoints; ++j) CHECK(pb.G[e * kArmJoints + j] == env.vmax()[j]);
          ++checked;
        } else {
          // Autoreset: the new episode starts safe.
          const ArmEval now = env.evaluate_reference(&env.q()[e * kArmJoints]);
          CHECK(now.c.maxCoeff() <= -env.config().init_margin);
          CHECK(!now.collision);
          CHECK(env.buffers().obs[e * kArmObsDim] == static_cast<float>(env.q()[e * kArmJoints]));
        }
      }
    }
    CHECK(checked > 100);
    CHECK(collisions > 0);  // random actions do collide without ATACOM
  }
}

TEST_CASE("satisfied constraints imply no ground-truth collision", "[arm_env]") {
  for (ArmTask task : kTasks) {
    ArmEnv env(default_arm_env_config(task), 1);
    const auto& tol = env.spec().constraint_tolerance;
    Rng rng(23, 0);
    int safe = 0, near_boundary = 0, collide = 0;
    const int trials = sanitizer_scaled(40000);
    for (int trial = 0; trial < trials; ++trial) {
      const auto q = random_q(env.model(), rng, 0.0);
      const ArmEval ev = env.evaluate_reference(q.data());
      bool ok = true;
      double worst = -1e9;
      for (int r = 0; r < kArmRows; ++r) {
        ok = ok && ev.c(r) <= tol[r];
        worst = std::max(worst, ev.c(r) - tol[r]);
      }
      collide += ev.collision;
      if (!ok) continue;
      ++safe;
      near_boundary += worst > -0.01;
      INFO("q = " << Eigen::Map<const ArmQ>(q.data()).transpose());
      CHECK(!ev.collision);
      CHECK(!ev.joint_violation);
    }
    CHECK(safe > trials / 10);
    CHECK(near_boundary > trials / 400);  // the sample reaches the boundary, so the check can fail
    CHECK(collide > trials / 40);
  }
}

TEST_CASE("shoulder links cannot reach the base or the head", "[arm_env]") {
  ArmEnv env(default_arm_env_config(ArmTask::Table), 1);
  const TiagoArmModel& m = env.model();
  Rng rng(29, 0);
  for (int trial = 0; trial < 5000; ++trial) {
    const auto q = random_q(m, rng);
    const ArmFkResult fk = arm_fk_reference(m, Eigen::Map<const ArmQ>(q.data()));
    for (const ArmCapsule& cap : m.capsules) {
      if (cap.body_check) continue;
      const Eigen::Vector3d a = fk.frame[cap.frame].apply(cap.a), b = fk.frame[cap.frame].apply(cap.b);
      CHECK(segment_distance(env.scene().body.shapes[0], a, b) > cap.radius);  // base
      CHECK(segment_distance(env.scene().body.shapes[2], a, b) > cap.radius);  // head
    }
  }
}

TEST_CASE("arm env is deterministic across thread counts", "[arm_env]") {
  for (ArmTask task : kTasks) {
    const int N = 600;  // several parallel blocks
    uint64_t hashes[3];
    const int threads[3] = {1, 2, 4};
    for (int t = 0; t < 3; ++t) {
      set_num_threads(threads[t]);
      ArmEnv env(default_arm_env_config(task), N);
      env.seed(42);
      Rng rng(43, 0);
      for (int s = 0; s < 40; ++s) env.step(random_arm_actions(rng, N).data());
      hashes[t] = state_hash(env);
    }
    set_num_threads(0);
    CHECK(hashes[0] == hashes[1]);
    CHECK(hashes[0] == hashes[2]);
    // Another seed gives another state.
    ArmEnv other(default_arm_env_config(task), N);
    other.seed(41);
    Rng rng(43, 0);
    for (int s = 0; s < 40; ++s) other.step(random_arm_actions(rng, N).data());
    CHECK(state_hash(other) != hashes[0]);
  }
}

TEST_CASE("arm env snapshot and restore re-step identically", "[arm_env]") {
  const int N = 50;
  ArmEnv env(default_arm_env_config(ArmTask::Shelf), N);
  env.seed(8);
  Rng rng(9, 0);
  for (int s = 0; s < 30; ++s) env.step(random_arm_actions(rng, N).data());
  std::stringstream snap;
  env.save_state(snap);
  const Rng rng_saved = rng;
  for (int s = 0; s < 30; ++s) env.step(random_arm_actions(rng, N).data());
  const uint64_t h1 = state_hash(env);
  ArmEnv other(default_arm_env_config(ArmTask::Shelf), N);
  other.seed(1234);
  other.load_state(snap);
  rng = rng_saved;
  for (int s = 0; s < 30; ++s) other.step(random_arm_actions(rng, N).data());
  CHECK(state_hash(other) == h1);
  std::stringstream wrong;
  ArmEnv small(default_arm_env_config(ArmTask::Shelf), 3);
  small.save_state(wrong);
  CHECK_THROWS_WITH(env.load_state(wrong), Catch::Contains("snapshot"));
}

TEST_CASE("NaN actions are treated as zero and counted", "[arm_env]") {
  ArmEnv env(default_arm_env_config(ArmTask::Table), 2);
  env.seed(5);
  const std::vector<double> q0 = env.q();
  std::vector<double> a(2 * kArmJoints, 0.0);
  a[3] = std::nan("");
  a[kArmJoints + 1] = INFINITY;
  env.step(a.data());
  const auto& names = env.spec().info_names;
  const size_t col = std::find(names.begin(), names.end(), "nan_action") - names.begin();
  CHECK(env.buffers().info[col] == 1.0f);
  CHECK(env.buffers().info[names.size() + col] == 1.0f);
  for (size_t i = 0; i < q0.size(); ++i) CHECK(env.q()[i] == q0[i]);
}

TEST_CASE("goals are reachable: sampled from safe configurations in the goal region", "[arm_env]") {
  for (ArmTask task : kTasks) {
    const int N = 64;
    ArmEnv env(default_arm_env_config(task), N);
    env.seed(77);
    int fallbacks = 0;
    for (int e = 0; e < N; ++e) {
      const Eigen::Vector3d g(env.goal()[e * 3], env.goal()[e * 3 + 1], env.goal()[e * 3 + 2]);
      CHECK(env.scene().goal_region.contains(g));
      const Eigen::Vector3d p(env.grasp()[e * 3], env.grasp()[e * 3 + 1], env.grasp()[e * 3 + 2]);
      CHECK((g - p).norm() >= env.config().goal_min_distance);
      fallbacks += env.buffers().info[e * env.spec().info_names.size() + 7] > 0;
    }
    CHECK(fallbacks == 0);
    // Observation inside its bounds.
    const EnvSpec& s = env.spec();
    for (int e = 0; e < N; ++e)
      for (int d = 0; d < s.obs_dim; ++d) {
        CHECK(env.buffers().obs[e * s.obs_dim + d] >= s.obs_low[d]);
        CHECK(env.buffers().obs[e * s.obs_dim + d] <= s.obs_high[d]);
      }
  }
}

namespace {
struct RolloutStats {
  int64_t steps = 0, collisions = 0, joint_violations = 0, violations = 0, episodes = 0;
  double max_excess = -1e300;  // max over steps and rows of c - tolerance
  double max_c = -1e300;
};

// Uniform random alpha for `steps` batched steps through the registry's env,
// with SafeEnv (ATACOM) between the policy and the env or without it.
RolloutStats random_rollout(ArmTask task, int N, int steps, uint64_t seed, bool atacom) {
  std::unique_ptr<BatchEnv> env = make_env({arm_task_name(task), N, atacom ? SafetyLayer::Atacom : SafetyLayer::None, nlohmann::json::object()});
  env->seed(seed);
  Rng rng(seed, 1u << 20);
  const EnvSpec& spec = env->spec();
  const auto& tol = spec.constraint_tolerance;
  const size_t ni = spec.info_names.size();
  std::vector<double> alpha(static_cast<size_t>(N) * spec.act_dim);
  RolloutStats st;
  for (int s = 0; s < steps; ++s) {
    for (double& x : alpha) x = rng.uniform(-1.0, 1.0);
    env->step(alpha.data());
    const EnvBuffers& b = env->buffers();
    for (int e = 0; e < N; ++e) {
      st.collisions += b.info[e * ni + 0] > 0;
      st.joint_violations += b.info[e * ni + 1] > 0;
      st.episodes += b.done(e);
      bool v = false;
      for (int r = 0; r < kArmRows; ++r) {
        const double c = b.constraints[e * kArmRows + r];
        st.max_c = std::max(st.max_c, c);
        st.max_excess = std::max(st.max_excess, c - tol[r]);
        v = v || c > tol[r];
      }
      st.violations += v;
    }
    st.steps += N;
  }
  return st;
}
}  // namespace

TEST_CASE("ATACOM keeps random exploration safe (short)", "[arm_env]") {
  for (ArmTask task : kTasks) {
    const RolloutStats safe = random_rollout(task, 64, 150, 1, true);
    CHECK(safe.collisions == 0);
    CHECK(safe.joint_violations == 0);
    CHECK(safe.max_excess <= 0.0);
    const RolloutStats raw = random_rollout(task, 64, 150, 1, false);
    CHECK(raw.collisions + raw.joint_violations > 0);
  }
}

TEST_CASE("100k+ steps of random alpha through ATACOM: no collision, constraints within tolerance", "[arm_env][slow]") {
  for (ArmTask task : kTasks) {
    for (uint64_t seed : {11u, 12u, 13u}) {
      const RolloutStats safe = random_rollout(task, 512, 500, seed, true);  // 256k env steps
      INFO(arm_task_name(task) << " seed " << seed << " max c " << safe.max_c);
      CHECK(safe.steps == 256000);
      CHECK(safe.collisions == 0);
      CHECK(safe.joint_violations == 0);
      CHECK(safe.violations == 0);
      CHECK(safe.max_excess <= 0.0);
      const RolloutStats raw = random_rollout(task, 512, 500, seed, false);
      INFO("without ATACOM: collisions " << raw.collisions << " joint violations " << raw.joint_violations);
      CHECK(raw.collisions > 0);
      CHECK(raw.joint_violations > 0);
    }
  }
}

TEST_CASE("set_state places an env and refreshes its model and observation", "[arm_env]") {
  ArmEnv env(default_arm_env_config(ArmTask::Table), 3);
  const auto& home = env.config().home;
  const double goal[3] = {0.6, -0.3, 0.8};
  env.set_state(1, home.data(), goal);
  const ArmEval ev = env.evaluate_reference(home.data());
  for (int r = 0; r < 3; ++r) {
    CHECK(env.grasp()[3 + r] == Approx(ev.grasp_p(r)).margin(1e-12));
    CHECK(env.buffers().obs[kArmObsDim + 7 + r] == static_cast<float>(goal[r]));
  }
  ProjectorBatch pb(env.projector_model(), 3);
  env.constraint_model(pb, 1, 2);
  for (int r = 0; r < kArmRows; ++r) CHECK(std::abs(pb.c[kArmRows + r] - ev.c(r)) < 1e-12);
}

TEST_CASE("table/shelf: per-env SAC defaults (reference 5.4) under the run config", "[arm_env]") {
  for (const char* env : {"table", "shelf"}) {
    RunConfig rc = resolve_run_config({{"train", {{"env", env}, {"algo", "atacom-sac"}}}});
    SacConfig c = rc.learner.get<SacConfig>();  // the "sac" section the SAC learner owns
    CHECK(c.lr_actor == 3e-4);
    CHECK(c.lr_critic == 3e-4);
    CHECK(c.lr_alpha == 1e-6);
    REQUIRE(c.target_entropy.has_value());
    CHECK(*c.target_entropy == -10.0);
    c = resolve_run_config({{"train", {{"env", env}, {"algo", "sac"}}}}).learner.get<SacConfig>();
    CHECK(c.lr_actor == 1e-5);
    CHECK(c.lr_critic == 1e-5);
    // The file's keys win over the env's; null target entropy means -act_dim.
    c = resolve_run_config({{"train", {{"env", env}, {"algo", "sac"}}},
                            {"sac", {{"lr_actor", 2e-4}, {"target_entropy", nullptr}}}}).learner.get<SacConfig>();
    CHECK(c.lr_actor == 2e-4);
    CHECK(c.lr_critic == 1e-5);
    CHECK(!c.target_entropy.has_value());
    CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", env}}}, {"sac", {{"lr_actr", 1.0}}}}),
                      Catch::Contains("lr_actr"));
  }
  // Envs without their own defaults keep the global ones.
  const RunConfig p = resolve_run_config({{"train", {{"env", "pendulum"}}}});
  CHECK(p.learner.get<SacConfig>().lr_actor == default_sac_config().lr_actor);
}
