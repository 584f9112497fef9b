// ShelfEnvReal protocol: bookkeeping with trivial policies, the linear
// attractor with and without ATACOM, and every layer against its training
// wrapper.
#include <catch2/catch.hpp>

#include <memory>
#include <vector>

#include "atacom/rng.hpp"
#include "atacom/safety_layer.hpp"
#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/arm_env.hpp"
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
  c.layer = ShelfRealLayer::None;
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
  c = default_shelf_real_config();
  c.layer = ShelfRealLayer::Cbf;
  c.cbf_gamma = 0.0;
  CHECK_THROWS_WITH(evaluate_shelf_real(default_arm_env_config(ArmTask::Shelf), c, *zero), Catch::Contains("cbf_gamma"));
  CHECK_THROWS_WITH(parse_shelf_real_layer("qp"), Catch::Contains("none, atacom, safelayer, cbf"));
}

// The protocol's own layer code against the wrappers training uses
// (src/safety/): one target that nobody finishes, so the phase runs its full
// length, and its final error is the mean distance after that many steps of
// the same policy through the wrapped env.
TEST_CASE("shelf-real protocol: each layer acts as its training wrapper", "[shelf_real]") {
  const ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
  ArmAttractorPolicy la(ec);
  const int N = 6, steps = 40;
  for (const std::string name : {"atacom", "safelayer", "cbf"}) {  // none: the attractor collides, and the env resets
    INFO("layer " << name);
    ShelfRealConfig c = default_shelf_real_config();
    c.trials = N;
    c.targets = 1;
    c.seed = 3;
    c.layer = parse_shelf_real_layer(name);
    CHECK(shelf_real_layer_name(c.layer) == name);
    c.cbf_gamma = 5.0;
    c.success_radius = 1e-9;
    c.hold_time = 1.0;
    c.max_time_per_target = steps * ec.dt;
    const ShelfRealResult r = evaluate_shelf_real(ec, c, la);
    REQUIRE(r.total_collisions == 0);

    ArmEnvConfig wc = ec;
    wc.horizon = steps + 1;  // as the protocol sets it
    const nlohmann::json params = name == "cbf" ? nlohmann::json{{"gamma", 5.0}} : nlohmann::json(nullptr);
    auto env = wrap_safety(std::make_unique<ArmEnv>(wc, N), SafetyLayer::parse(name), params);
    env->seed(c.seed);
    std::vector<Rng> rngs;
    for (int e = 0; e < N; ++e) rngs.emplace_back(c.seed, (uint64_t{7} << 32) | uint64_t(e));
    std::vector<double> action(size_t(N) * kArmJoints);
    for (int s = 0; s < steps; ++s) {
      la.act(env->buffers().obs.data(), N, true, rngs.data(), action.data());
      env->step(action.data());
      for (int e = 0; e < N; ++e) REQUIRE(!env->buffers().terminated[e]);
    }
    const size_t ni = env->spec().info_names.size();
    double mean = 0.0;
    for (int e = 0; e < N; ++e) mean += env->buffers().info[e * ni + 3];  // distance
    mean /= N;
    CHECK(r.targets[0].final_error_mean == Approx(mean).epsilon(1e-9));
  }
}
