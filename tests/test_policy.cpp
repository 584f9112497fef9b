// Policies behind the one contract: random and zero, and the env families'
// linear attractors (LA reaches unobstructed goals; LA-ATACOM stays
// collision-free; the arm's joint-limit band is the intended one).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/policy.hpp"
#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "envs/nav/nav_env.hpp"

using namespace atacom;

TEST_CASE("policy: random draws row i from rngs[i], zero is zero", "[policy]") {
  const auto r = make_random_policy(4, 3);
  std::vector<Rng> a = {Rng(5, 0), Rng(5, 1), Rng(5, 2)};
  std::vector<double> batch(9);
  r->act(nullptr, 3, true, a.data(), batch.data());
  for (int i = 0; i < 3; ++i) {
    Rng one(5, uint64_t(i));
    double row[3];
    r->act(nullptr, 1, false, &one, row);
    for (int j = 0; j < 3; ++j) {
      CHECK(row[j] == batch[size_t(i) * 3 + j]);
      CHECK(std::abs(row[j]) <= 1.0);
    }
  }
  CHECK_THROWS(r->act(nullptr, 1, false, nullptr, batch.data()));
  const auto z = make_zero_policy(4, 3);
  std::vector<double> out(6, 7.0);
  z->act(nullptr, 2, false, nullptr, out.data());
  for (double v : out) CHECK(v == 0.0);
  CHECK_THROWS_WITH(make_attractor_policy("pendulum", nlohmann::json::object()),
                    Catch::Contains("table, shelf, nav"));
}

TEST_CASE("arm attractor: the joint-limit band is max(-v, 5 (q_low - q)) .. min(v, 5 (q_up - q))", "[policy]") {
  // The public reference writes the lower bound as -max(v, 5 (q_low - q)) = -v:
  // a joint next to its lower limit still runs at full speed into it. Here
  // it slows down: a q_j a little above its limit with a goal that pulls
  // it down gets at most 5 (q_low - q) (and symmetrically at the upper limit).
  const ArmEnvConfig ec = default_arm_env_config(ArmTask::Table);
  const ArmAttractorPolicy la(ec);
  const TiagoArmModel model = load_tiago_arm_model(ec.torso_lift);
  Rng rng(3, 0);
  int limited_low = 0, limited_high = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int j = trial % kArmJoints;
    const bool low = (trial / kArmJoints) % 2 == 0;
    float obs[kArmObsDim] = {};
    ArmQ q;
    for (int k = 0; k < kArmJoints; ++k)
      q(k) = model.lower[size_t(k)] + rng.uniform(0.3, 0.7) * (model.upper[size_t(k)] - model.lower[size_t(k)]);
    const double gap = rng.uniform(0.005, 0.1);
    q(j) = low ? model.lower[size_t(j)] + gap : model.upper[size_t(j)] - gap;
    // the goal: where the grasping frame is when joint j is far past its limit
    ArmQ far = q;
    far(j) += low ? -1.0 : 1.0;
    const Eigen::Vector3d goal = arm_fk_reference(model, far).grasp.p;
    for (int k = 0; k < kArmJoints; ++k) obs[k] = float(q(k));
    for (int r = 0; r < 3; ++r) obs[7 + r] = float(goal(r));
    double a[kArmJoints];
    la.act_one(obs, a);
    const double v = ec.velocity_scale * model.velocity[size_t(j)];
    const double qj = double(obs[j]);
    for (int k = 0; k < kArmJoints; ++k) CHECK(std::abs(a[k]) <= 1.0);
    if (low) {
      CHECK(a[j] * v >= 5.0 * (model.lower[size_t(j)] - qj) - 1e-9);
      limited_low += std::abs(a[j] * v - 5.0 * (model.lower[size_t(j)] - qj)) < 1e-9;
    } else {
      CHECK(a[j] * v <= 5.0 * (model.upper[size_t(j)] - qj) + 1e-9);
      limited_high += std::abs(a[j] * v - 5.0 * (model.upper[size_t(j)] - qj)) < 1e-9;
    }
  }
  INFO("samples held at the band: lower " << limited_low << ", upper " << limited_high);
  CHECK(limited_low > 20);   // the band is what stopped them (not a test that cannot fail)
  CHECK(limited_high > 20);
}

TEST_CASE("arm attractor: LA reaches unobstructed goals within 4 s", "[policy]") {
  // Goals where the grasping frame is at a configuration 0.25 rad away per
  // joint (well inside the limits): short, free paths above the table.
  const int N = 24;
  const ArmEnvConfig ec = default_arm_env_config(ArmTask::Table);
  ArmEnv env(ec, N);
  env.seed(5);
  ArmAttractorPolicy la(ec);
  Rng rng(8, 0);
  std::vector<double> d0(N);
  for (int i = 0; i < N; ++i) {
    ArmQ q, g;
    for (int k = 0; k < kArmJoints; ++k) {
      q(k) = env.q()[size_t(i) * kArmJoints + k];
      const double lo = env.model().lower[size_t(k)] + 0.3, hi = env.model().upper[size_t(k)] - 0.3;
      g(k) = std::clamp(q(k) + (rng.uniform() < 0.5 ? -0.25 : 0.25), lo, hi);
    }
    const Eigen::Vector3d goal = arm_fk_reference(env.model(), g).grasp.p;
    env.set_goal(i, goal.data());
    d0[size_t(i)] = (goal - arm_fk_reference(env.model(), q).grasp.p).norm();
  }
  std::vector<double> a(size_t(N) * kArmJoints);
  std::vector<uint8_t> ended(N, 0);
  const int steps = int(std::lround(4.0 / ec.dt));
  for (int t = 0; t < steps; ++t) {
    std::vector<float> obs = env.buffers().obs;
    la.act(obs.data(), N, true, nullptr, a.data());
    env.step(a.data());
    for (int i = 0; i < N; ++i) ended[size_t(i)] |= env.buffers().done(i);
  }
  int reached = 0, free = 0;
  for (int i = 0; i < N; ++i) {
    if (ended[size_t(i)]) continue;  // hit something on the way (or the horizon): not an unobstructed run
    ++free;
    double d = 0;
    for (int r = 0; r < 3; ++r) d += std::pow(env.grasp()[size_t(i) * 3 + r] - env.goal()[size_t(i) * 3 + r], 2);
    d = std::sqrt(d);
    INFO("env " << i << ": distance " << d0[size_t(i)] << " -> " << d);
    CHECK(d < 0.01);
    reached += d < 0.01;
  }
  CHECK(free >= N - 2);
  CHECK(reached == free);
}

TEST_CASE("nav attractor: LA reaches unobstructed goals within 10 s", "[policy]") {
  // Fetch parked in a corner (speed limits ~0), TIAGo and its goal in the free half of the room.
  nlohmann::json cfg = {{"fetch", {{"policy", {{"v_max", 1e-6}, {"w_max", 1e-6}}}}}};
  const nlohmann::json resolved = resolve_env_config("nav", cfg);
  NavConfig nc;
  from_json(resolved, nc);
  const int N = 16;
  NavEnv env(nc, N);
  env.seed(2);
  Rng rng(4, 0);
  for (int i = 0; i < N; ++i) {
    const double tiago[3] = {rng.uniform(0.3, 2.5), rng.uniform(-1.5, 1.5), rng.uniform(-3.1, 3.1)};
    const double goal[2] = {rng.uniform(0.3, 2.5), rng.uniform(-1.5, 1.5)};
    const double fetch[3] = {-2.6, -1.6, 0.0};
    env.place(i, tiago, fetch, goal, fetch);
  }
  auto la = make_attractor_policy("nav", resolved);
  std::vector<double> a(size_t(N) * 2);
  const size_t ni = env.spec().info_names.size();
  std::vector<uint8_t> reached(N, 0), hit(N, 0);
  for (int t = 0; t < 300; ++t) {
    std::vector<float> obs = env.buffers().obs;
    la->act(obs.data(), N, true, nullptr, a.data());
    env.step(a.data());
    for (int i = 0; i < N; ++i) {
      if (env.buffers().terminated[size_t(i)]) hit[size_t(i)] = 1;
      if (!hit[size_t(i)] && env.buffers().info[size_t(i) * ni + kNavInfoFinalDistance] < nc.reward.goal_radius)
        reached[size_t(i)] = 1;
    }
  }
  for (int i = 0; i < N; ++i) {
    INFO("env " << i);
    CHECK(!hit[size_t(i)]);
    CHECK(reached[size_t(i)]);
  }
}

TEST_CASE("attractors: LA-ATACOM stays collision-free on random goals (table, shelf)", "[policy]") {
  for (const char* name : {"table", "shelf"}) {
    INFO("env " << name);
    const int N = 32;
    auto env = make_env(EnvRequest{name, N, SafetyLayer::Atacom});
    auto la = make_attractor_policy(name, resolve_env_config(name, nlohmann::json::object()));
    env->seed(17);
    const EnvSpec& spec = env->spec();
    const size_t ni = spec.info_names.size();
    int collisions = 0, violations = 0, episodes = 0;
    std::vector<double> a(size_t(N) * spec.act_dim);
    for (int t = 0; t < 600; ++t) {  // 20 s: more than one episode of every env (autoreset draws new goals)
      std::vector<float> obs = env->buffers().obs;
      la->act(obs.data(), N, true, nullptr, a.data());
      env->step(a.data());
      const EnvBuffers& b = env->buffers();
      for (int i = 0; i < N; ++i) {
        collisions += b.info[size_t(i) * ni] > 0;  // info column 0: ground-truth collision
        episodes += b.done(i);
        for (int r = 0; r < spec.num_constraints; ++r)
          violations += b.constraints[size_t(i) * spec.num_constraints + r] > spec.constraint_tolerance[size_t(r)];
      }
    }
    REQUIRE(spec.info_names[0] == "collision");
    CHECK(episodes >= N);
    CHECK(collisions == 0);
    CHECK(violations == 0);
  }
}
