#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "envs/nav/nav_attractor.hpp"
#include "envs/nav/nav_env.hpp"

using namespace atacom;

TEST_CASE("nav attractor: strict JSON round trip", "[nav_attractor]") {
  const nlohmann::json j = default_nav_attractor_params();
  NavAttractorParams p;
  p.k_v = 9.0;
  from_json(j, p);
  REQUIRE(nlohmann::json(p) == j);
  nlohmann::json bad = j;
  bad["k_x"] = 1.0;
  REQUIRE_THROWS_WITH(from_json(bad, p), Catch::Contains("k_x"));
  bad = j;
  bad["w_max"] = 0.0;
  REQUIRE_THROWS(from_json(bad, p));
}

TEST_CASE("nav attractor: normalised v and omega from the observation", "[nav_attractor]") {
  const NavAttractorParams p = default_nav_attractor_params();
  std::vector<float> obs(3 * kNavObsDim, 0.0f);
  // env 0: goal 0.5 m straight ahead; env 1: goal 3 m behind; env 2: goal
  // 0.3 m to the left of a robot heading +y at (1, 1).
  obs[0] = 0.5f; obs[4] = 1.0f;
  float* o1 = &obs[kNavObsDim];
  o1[0] = -3.0f; o1[4] = 1.0f;
  float* o2 = &obs[2 * kNavObsDim];
  o2[0] = 0.7f; o2[1] = 1.0f; o2[2] = 1.0f; o2[3] = 1.0f; o2[5] = 1.0f;
  double a[6];
  nav_linear_attractor(p, obs.data(), kNavObsDim, 3, a);
  REQUIRE(a[0] == Approx(0.5));
  REQUIRE(a[1] == Approx(0.0).margin(1e-12));
  REQUIRE(a[2] == Approx(1.0));   // v = |e| = 3, clipped at 1
  REQUIRE(a[3] == Approx(1.0));   // omega = pi, clipped at 1.57, then at w_max
  REQUIRE(a[4] == Approx(0.3).epsilon(1e-6));
  REQUIRE(a[5] == Approx(1.0));   // heading error +pi/2 > w_max
}

namespace {

struct LaResult {
  int episodes = 0, collisions = 0, at_goal = 0;
};

LaResult run_la(bool atacom) {
  const int N = 64;
  EnvRequest req;
  req.name = "nav";
  req.num_envs = N;
  req.safety = atacom ? SafetyLayer::Atacom : SafetyLayer::None;
  auto env = make_env(req);
  env->seed(9);
  const NavAttractorParams p = default_nav_attractor_params();
  const size_t ni = env->spec().info_names.size();
  std::vector<double> a(2 * N);
  LaResult r;
  for (int t = 0; t < 1000; ++t) {
    nav_linear_attractor(p, env->buffers().obs.data(), kNavObsDim, N, a.data());
    env->step(a.data());
    for (int i = 0; i < N; ++i) {
      if (!env->buffers().done(i)) continue;
      const float* info = &env->buffers().info[ni * i];
      ++r.episodes;
      const bool collided = info[kNavInfoCollision] > 0.0f;
      r.collisions += collided;
      r.at_goal += !collided && info[kNavInfoAtGoal] > 0.0f;  // success: at the goal at the horizon
    }
  }
  return r;
}

}  // namespace

TEST_CASE("nav attractor: LA reaches the goal, LA-ATACOM collides less", "[nav_attractor]") {
  const LaResult la = run_la(false), la_atacom = run_la(true);
  INFO("LA: " << la.episodes << " episodes, " << la.collisions << " collisions, " << la.at_goal
              << " ended at the goal without a collision; LA-ATACOM: " << la_atacom.episodes << " episodes, " << la_atacom.collisions
              << " collisions, " << la_atacom.at_goal << " ended at the goal");
  REQUIRE(la.episodes >= 128);
  REQUIRE(la.at_goal >= 0.5 * (la.episodes - la.collisions));
  REQUIRE(la_atacom.collisions * 10 < la.collisions);
  REQUIRE(la_atacom.at_goal >= 0.6 * la_atacom.episodes);
}
