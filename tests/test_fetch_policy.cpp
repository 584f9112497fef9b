#include <catch2/catch.hpp>

#include <cmath>

#include <nlohmann/json.hpp>

#include "envs/nav/fetch_policy.hpp"
#include "atacom/rng.hpp"

using namespace atacom;

TEST_CASE("fetch policy: strict JSON round trip", "[fetch_policy]") {
  const FetchPolicyParams p = default_fetch_policy_params();
  nlohmann::json j = p;
  FetchPolicyParams q;
  q.k_v = 123.0;
  from_json(j, q);
  REQUIRE(nlohmann::json(q) == j);
  nlohmann::json extra = j;
  extra["speed"] = 1.0;
  REQUIRE_THROWS_WITH(from_json(extra, q), Catch::Contains("unknown config key 'fetch_policy.speed'"));
  nlohmann::json missing = j;
  missing.erase("k_w");
  REQUIRE_THROWS_WITH(from_json(missing, q), Catch::Contains("missing config key 'fetch_policy.k_w'"));
  nlohmann::json bad = j;
  bad["v_max"] = -0.7;
  REQUIRE_THROWS_WITH(from_json(bad, q), Catch::Contains("v_max"));
}

TEST_CASE("fetch policy: go-to-goal law, caps and arrival", "[fetch_policy]") {
  const FetchPolicyParams p = default_fetch_policy_params();
  const double pose[3] = {0.0, 0.0, 0.0};
  {  // facing a goal 1 m ahead: v = 0.5 * 1, no turn
    const double goal[2] = {1.0, 0.0};
    const FetchCommand c = fetch_command(p, pose, goal);
    REQUIRE(c.v == Approx(0.5));
    REQUIRE(c.w == Approx(0.0).margin(1e-15));
    REQUIRE_FALSE(c.arrived);
  }
  {  // far goal behind and to the left: speed and turn rate capped
    const double goal[2] = {-2.0, 0.5};
    const FetchCommand c = fetch_command(p, pose, goal);
    REQUIRE(c.v == Approx(0.7));
    REQUIRE(c.w == Approx(1.5));
  }
  {  // goal 0.05 m ahead: arrived; 0.05 m to the side: not facing it
    const double ahead[2] = {0.05, 0.0}, side[2] = {0.0, 0.05};
    REQUIRE(fetch_command(p, pose, ahead).arrived);
    REQUIRE_FALSE(fetch_command(p, pose, side).arrived);
  }
}

TEST_CASE("fetch policy: slows down only when heading out near a wall", "[fetch_policy]") {
  const FetchPolicyParams p = default_fetch_policy_params();
  const double goal_far[2] = {100.0, 0.0};
  const double out[3] = {2.85, 0.0, 0.0};       // 0.25 past slow_x, heading +x
  const double in[3] = {2.85, 0.0, M_PI};       // same spot, heading back in
  const double goal_back[2] = {-100.0, 0.0};
  REQUIRE(fetch_command(p, out, goal_far).v == Approx(0.7 * 0.5));
  REQUIRE(fetch_command(p, in, goal_back).v == Approx(0.7));
  const double stop[3] = {2.6 + p.slow_width + 0.01, 0.0, 0.0};
  REQUIRE(fetch_command(p, stop, goal_far).v == 0.0);
  const double y_out[3] = {0.0, -1.8, -M_PI / 2};  // 0.2 past slow_y, heading -y
  const double goal_down[2] = {0.0, -100.0};
  REQUIRE(fetch_command(p, y_out, goal_down).v == Approx(0.7 * (1.0 - 0.2 / 0.5)));
}

TEST_CASE("fetch policy: reaches random goals in the room and stays off the walls", "[fetch_policy]") {
  // Closed-loop on the exact unicycle at 30 Hz, goals drawn as in the env.
  const FetchPolicyParams p = default_fetch_policy_params();
  const double dt = 1.0 / 30.0, sx = 0.75 * 3.5, sy = 0.75 * 2.5, r_fetch = 0.3;
  Rng rng(3, 0);
  int reached = 0, worst_steps = 0;
  double max_x = 0.0, max_y = 0.0;
  for (int trial = 0; trial < 300; ++trial) {
    double q[3] = {rng.uniform(-sx, sx), rng.uniform(-sy, sy), rng.uniform(-M_PI, M_PI)};
    const double goal[2] = {rng.uniform(-sx, sx), rng.uniform(-sy, sy)};
    for (int t = 0; t < 1500; ++t) {
      const FetchCommand c = fetch_command(p, q, goal);
      if (c.arrived) {
        ++reached;
        worst_steps = std::max(worst_steps, t);
        break;
      }
      const double th = q[2] + c.w * dt;
      if (std::abs(c.w) > 1e-12) {
        q[0] += c.v / c.w * (std::sin(th) - std::sin(q[2]));
        q[1] -= c.v / c.w * (std::cos(th) - std::cos(q[2]));
      } else {
        q[0] += c.v * dt * std::cos(q[2]);
        q[1] += c.v * dt * std::sin(q[2]);
      }
      q[2] = th;
      max_x = std::max(max_x, std::abs(q[0]));
      max_y = std::max(max_y, std::abs(q[1]));
    }
  }
  INFO("worst steps to a goal " << worst_steps << ", max |x| " << max_x << ", max |y| " << max_y);
  REQUIRE(reached == 300);
  REQUIRE(worst_steps < 1000);  // about 33 s; a typical goal takes 8-12 s
  REQUIRE(max_x + r_fetch < 3.5);
  REQUIRE(max_y + r_fetch < 2.5);
}

TEST_CASE("fetch policy: wrap_angle", "[fetch_policy]") {
  REQUIRE(wrap_angle(0.5) == 0.5);
  REQUIRE(wrap_angle(2 * M_PI + 0.25) == Approx(0.25));
  REQUIRE(wrap_angle(-3 * M_PI / 2) == Approx(M_PI / 2));
  REQUIRE(std::abs(wrap_angle(7.0 * M_PI)) == Approx(M_PI));
}
