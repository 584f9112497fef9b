#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "envs/pendulum/pendulum.hpp"

using atacom::PendulumEnv;

namespace {
// Gymnasium Pendulum-v1 step, written out literally (Python's % is a floor modulo).
struct Gym {
  double th, thdot;
  double step(double u) {
    const double g = 10.0, m = 1.0, l = 1.0, dt = 0.05, pi = M_PI;
    u = std::min(std::max(u, -2.0), 2.0);
    double a = std::fmod(th + pi, 2 * pi);
    if (a < 0) a += 2 * pi;
    a -= pi;
    const double costs = a * a + 0.1 * thdot * thdot + 0.001 * u * u;
    double newthdot = thdot + (3 * g / (2 * l) * std::sin(th) + 3.0 / (m * l * l) * u) * dt;
    newthdot = std::min(std::max(newthdot, -8.0), 8.0);
    th = th + newthdot * dt;
    thdot = newthdot;
    return -costs;
  }
};
}  // namespace

TEST_CASE("pendulum: dynamics, reward and observation follow Pendulum-v1", "[pendulum]") {
  PendulumEnv env(atacom::default_pendulum_model(), 3);
  env.seed(11);
  std::vector<Gym> ref;
  for (int i = 0; i < 3; ++i) ref.push_back({env.theta(i), env.theta_dot(i)});
  const double pattern[3] = {0.7, -1.3, 0.05};  // includes an out-of-range action (clipped)
  for (int t = 0; t < 150; ++t) {
    std::vector<double> a(3);
    for (int i = 0; i < 3; ++i) a[size_t(i)] = std::sin(0.1 * t + pattern[i]) * 1.2;
    for (int i = 0; i < 3; ++i) ref[size_t(i)] = {env.theta(i), env.theta_dot(i)};  // one-step comparison
    env.step(a.data());
    const auto& b = env.buffers();
    for (int i = 0; i < 3; ++i) {
      const double r = ref[size_t(i)].step(2.0 * std::min(std::max(a[size_t(i)], -1.0), 1.0));
      // The build contracts a*b+c into FMAs (-ffp-contract=fast), possibly
      // differently in the two codes, so compare to rounding, not bits.
      REQUIRE(b.reward[size_t(i)] == Approx(r).epsilon(1e-6));
      REQUIRE(env.theta(i) == Approx(ref[size_t(i)].th).epsilon(1e-12));
      REQUIRE(env.theta_dot(i) == Approx(ref[size_t(i)].thdot).epsilon(1e-12).margin(1e-12));
      REQUIRE(b.obs[size_t(i) * 3 + 0] == Approx(std::cos(ref[size_t(i)].th)).margin(1e-6));
      REQUIRE(b.obs[size_t(i) * 3 + 1] == Approx(std::sin(ref[size_t(i)].th)).margin(1e-6));
      REQUIRE(b.obs[size_t(i) * 3 + 2] == Approx(ref[size_t(i)].thdot).margin(1e-5));
      REQUIRE(b.terminated[size_t(i)] == 0);
      REQUIRE(b.truncated[size_t(i)] == 0);
    }
  }
}

TEST_CASE("pendulum: initial states, truncation at 200 and same-step autoreset", "[pendulum]") {
  PendulumEnv env(atacom::default_pendulum_model(), 64);
  env.seed(3);
  for (int i = 0; i < 64; ++i) {
    REQUIRE(std::abs(env.theta(i)) <= M_PI);
    REQUIRE(std::abs(env.theta_dot(i)) <= 1.0);
  }
  std::vector<double> a(64, 0.3);
  double ret0 = 0;
  for (int t = 1; t <= 200; ++t) {
    env.step(a.data());
    const auto& b = env.buffers();
    ret0 += b.reward[0];
    REQUIRE(bool(b.truncated[0]) == (t == 200));
    if (t == 200) {
      REQUIRE(b.episode_length[0] == 200);
      REQUIRE(b.episode_return[0] == Approx(ret0).epsilon(1e-5));
      // final_obs is where the step went, obs the first state of the next episode
      REQUIRE(b.final_obs[2] != b.obs[2]);
      REQUIRE(std::abs(env.theta_dot(0)) <= 1.0);
    } else {
      REQUIRE(b.final_obs[0] == b.obs[0]);
    }
  }
  env.step(a.data());
  REQUIRE(env.buffers().truncated[0] == 0);
}

TEST_CASE("pendulum: per-env streams keyed by (seed, env id)", "[pendulum]") {
  PendulumEnv one(atacom::default_pendulum_model(), 1), four(atacom::default_pendulum_model(), 4),
      other(atacom::default_pendulum_model(), 1);
  one.seed(5);
  four.seed(5);
  other.seed(6);
  REQUIRE(one.theta(0) == four.theta(0));
  REQUIRE(one.theta_dot(0) == four.theta_dot(0));
  REQUIRE(four.theta(1) != four.theta(0));
  REQUIRE(other.theta(0) != one.theta(0));
}

TEST_CASE("pendulum: non-finite actions act as zero and are counted", "[pendulum]") {
  PendulumEnv a(atacom::default_pendulum_model(), 2), b(atacom::default_pendulum_model(), 2);
  a.seed(1);
  b.seed(1);
  const double bad[2] = {std::nan(""), INFINITY}, zero[2] = {0.0, 0.0};
  a.step(bad);
  b.step(zero);
  REQUIRE(a.theta(0) == b.theta(0));
  REQUIRE(a.theta(1) == b.theta(1));
  REQUIRE(a.buffers().info[1] == 1.0f);  // (env 0, nonfinite_action)
  REQUIRE(b.buffers().info[1] == 0.0f);
  REQUIRE(a.spec().info_names[1] == "nonfinite_action");
  REQUIRE(a.spec().info_reduce[1] == atacom::InfoReduce::Sum);
}

TEST_CASE("pendulum: save_state/load_state continues bitwise", "[pendulum]") {
  PendulumEnv env(atacom::default_pendulum_model(), 5);
  env.seed(9);
  std::vector<double> a(5);
  auto drive = [&](int steps, std::vector<float>* trace) {
    for (int t = 0; t < steps; ++t) {
      for (int i = 0; i < 5; ++i) a[size_t(i)] = std::cos(0.3 * t + i);
      env.step(a.data());
      if (trace) trace->insert(trace->end(), env.buffers().obs.begin(), env.buffers().obs.end());
    }
  };
  drive(190, nullptr);
  std::stringstream snap;
  env.save_state(snap);
  std::vector<float> first, second;
  drive(30, &first);  // crosses the autoreset at 200
  env.load_state(snap);
  drive(30, &second);
  REQUIRE(first == second);
  PendulumEnv wrong(atacom::default_pendulum_model(), 4);
  snap.seekg(0);
  REQUIRE_THROWS_WITH(wrong.load_state(snap), Catch::Contains("5 envs"));
  std::stringstream cut(snap.str().substr(0, 40));
  REQUIRE_THROWS_WITH(env.load_state(cut), Catch::Contains("truncated"));
}

TEST_CASE("pendulum: registry entry, strict config, no ATACOM", "[pendulum]") {
  atacom::EnvRequest req;
  req.name = "pendulum";
  req.num_envs = 2;
  auto env = atacom::make_env(req);
  REQUIRE(env->spec().obs_dim == 3);
  REQUIRE(env->spec().act_dim == 1);
  REQUIRE(env->spec().horizon == 200);
  REQUIRE(env->spec().dt == 0.05);
  REQUIRE(env->spec().obs_high[2] == 8.0f);
  req.config = {{"max_torque", 1.0}};
  REQUIRE(atacom::make_env(req)->spec().act_dim == 1);
  req.config = {{"max_torqe", 1.0}};
  REQUIRE_THROWS_WITH(atacom::make_env(req), Catch::Contains("max_torqe"));
  req.config = {{"horizon", 0}};
  REQUIRE_THROWS_WITH(atacom::make_env(req), Catch::Contains("horizon"));
  req.config = nlohmann::json::object();
  req.safety = atacom::SafetyLayer::Atacom;
  REQUIRE_THROWS_WITH(atacom::make_env(req), Catch::Contains("ATACOM"));
  atacom::PendulumModel m = atacom::default_pendulum_model();
  m.max_speed = 6.5;
  REQUIRE(nlohmann::json(m).get<atacom::PendulumModel>().max_speed == 6.5);
}
