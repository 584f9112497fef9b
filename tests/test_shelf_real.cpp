// ShelfEnvReal protocol: bookkeeping with trivial policies and the linear
// attractor with and without ATACOM.
#include <catch2/catch.hpp>

#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/shelf_real.hpp"

using namespace atacom;

TEST_CASE("shelf-real protocol: zero policy never succeeds and never collides", "[shelf_real]") {
  ShelfRealConfig c = default_shelf_real_config();
  c.trials = 6;
  c.max_time_per_target = 3.0;
  c.hold_time = 0.5;
  const auto zero = make_zero_policy(kArmObsDim, kArmJoints);
  const ShelfRealResult r = evaluate_shelf_real(default_arm_env_config(ArmTask::Shelf), c, *zero);
  REQUIRE(r.targets.size() == 2);
  for (const ShelfRealTarget& t : r.targets) {
    CHECK(t.success_rate == 0.0);
    CHECK(t.collisions == 0);
    CHECK(t.final_error_mean >= default_arm_env_config(ArmTask::Shelf).goal_min_distance - 1e-6);
  }
  CHECK(nlohmann::json(r)["targets"][1]["target"] == 2);
}

TEST_CASE("shelf-real protocol: linear attractor through ATACOM reaches targets safely", "[shelf_real]") {
  const ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
  ArmAttractorPolicy la(ec);
  ShelfRealConfig c = default_shelf_real_config();
  c.trials = 12;
  c.seed = 4;
  const ShelfRealResult safe = evaluate_shelf_real(ec, c, la);
  CHECK(safe.total_collisions == 0);
  CHECK(safe.max_constraint_violations == 0);
  for (const ShelfRealTarget& t : safe.targets) {
    CHECK(t.success_rate >= 0.5);
    CHECK(t.time_mean >= c.hold_time);
    CHECK(t.time_mean <= c.max_time_per_target);
  }
  c.atacom = false;
  const ShelfRealResult raw = evaluate_shelf_real(ec, c, la);
  CHECK(raw.total_collisions > 0);  // the straight-line attractor drives into the shelf
}

TEST_CASE("shelf-real protocol rejects bad settings", "[shelf_real]") {
  ShelfRealConfig c = default_shelf_real_config();
  c.hold_time = 20.0;
  const auto zero = make_zero_policy(kArmObsDim, kArmJoints);
  CHECK_THROWS_AS(evaluate_shelf_real(default_arm_env_config(ArmTask::Shelf), c, *zero), std::invalid_argument);
  // A run's env.dt can be any value in (0, 1): a tiny one is refused, naming env.dt, not run for hours.
  ArmEnvConfig tiny = default_arm_env_config(ArmTask::Shelf);
  tiny.dt = 1e-9;
  CHECK_THROWS_WITH(evaluate_shelf_real(tiny, default_shelf_real_config(), *zero), Catch::Contains("env.dt"));
}
