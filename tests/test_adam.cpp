#include <catch2/catch.hpp>

#include <cmath>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "train/adam.hpp"
#include "atacom/rng.hpp"

TEST_CASE("adam: matches the bias-corrected update rule", "[adam]") {
  atacom::Adam<double> opt(2, atacom::default_adam_config());
  std::vector<double> p = {1.0, -2.0};
  double m[2] = {0, 0}, v[2] = {0, 0}, ref[2] = {1.0, -2.0};
  for (int t = 1; t <= 5; ++t) {
    const std::vector<double> g = {0.5 * t, -0.1 / t};
    opt.step(p.data(), g.data(), 0.01);
    for (int i = 0; i < 2; ++i) {
      m[i] = 0.9 * m[i] + 0.1 * g[size_t(i)];
      v[i] = 0.999 * v[i] + 0.001 * g[size_t(i)] * g[size_t(i)];
      const double mh = m[i] / (1 - std::pow(0.9, t)), vh = v[i] / (1 - std::pow(0.999, t));
      ref[i] -= 0.01 * mh / (std::sqrt(vh) + 1e-8);
      REQUIRE(p[size_t(i)] == Approx(ref[i]).epsilon(1e-12));
    }
  }
  REQUIRE(opt.steps() == 5);
  std::stringstream s;
  opt.save(s);
  atacom::Adam<double> copy(2, atacom::default_adam_config());
  copy.load(s);
  std::vector<double> p2 = p;
  const std::vector<double> g = {0.3, 0.3};
  opt.step(p.data(), g.data(), 0.01);
  copy.step(p2.data(), g.data(), 0.01);
  REQUIRE(p == p2);
  atacom::Adam<double> wrong(3, atacom::default_adam_config());
  s.seekg(0);
  REQUIRE_THROWS_WITH(wrong.load(s), Catch::Contains("expected 3"));
}

TEST_CASE("adam: the fused step equals step + zero_grad + Polyak", "[adam]") {
  const size_t n = 40000;  // several parallel blocks
  std::vector<float> p(n), g(n), tgt(n);
  atacom::Rng r(3, 0);
  for (size_t i = 0; i < n; ++i) { p[i] = float(r.uniform(-1, 1)); g[i] = float(r.uniform(-1, 1)); tgt[i] = float(r.uniform(-1, 1)); }
  auto p2 = p, g2 = g, tgt2 = tgt;
  atacom::Adam<float> a(n, atacom::default_adam_config()), b(n, atacom::default_adam_config());
  for (int k = 0; k < 3; ++k) {
    a.step(p.data(), g.data(), 1e-3);
    atacom::polyak_update(tgt.data(), p.data(), n, 0.01);
    b.step_fused(p2.data(), g2.data(), 1e-3, tgt2.data(), 0.01);
    for (size_t i = 0; i < n; ++i) REQUIRE(g2[i] == 0.0f);
    g2 = g;
  }
  for (size_t i = 0; i < n; i += 97) {
    REQUIRE(p2[i] == Approx(p[i]).epsilon(1e-6).margin(1e-7));
    REQUIRE(tgt2[i] == Approx(tgt[i]).epsilon(1e-6).margin(1e-7));
  }
}

TEST_CASE("adam: moments never become subnormal (they would slow every update ~100x)", "[adam]") {
  // Step 0: half the gradients 1e-3, half 3e-25 (squares to a subnormal);
  // step 1: 1e-30 everywhere; then exactly 0 (a dead ReLU), so m decays by
  // 0.9 per step and, from 1e-4, would cross FLT_MIN near step 790.
  const size_t n = 64;
  for (int fused = 0; fused < 2; ++fused) {
    atacom::Adam<float> opt(n, atacom::default_adam_config());
    std::vector<float> p(n, 1.0f), g(n);
    bool subnormal = false, zero_m = false;
    for (int t = 0; t < 1200; ++t) {
      for (size_t i = 0; i < n; ++i) g[i] = t == 0 ? (i % 2 ? 1e-3f : 3e-25f) : t == 1 ? 1e-30f : 0.0f;
      if (fused) opt.step_fused(p.data(), g.data(), 1e-3);
      else opt.step(p.data(), g.data(), 1e-3);
      for (size_t i = 0; i < n; ++i) {
        subnormal = subnormal || std::fpclassify(opt.first_moment()[i]) == FP_SUBNORMAL ||
                    std::fpclassify(opt.second_moment()[i]) == FP_SUBNORMAL;
      }
    }
    for (float m : opt.first_moment()) zero_m = zero_m || m == 0.0f;
    INFO("fused " << fused);
    CHECK_FALSE(subnormal);
    CHECK(zero_m);  // the decayed moments reached 0 through the flush
    for (float x : p) CHECK(std::isfinite(x));
  }
}

TEST_CASE("adam: gradient clipping and Polyak averaging", "[adam]") {
  std::vector<float> g = {3.0f, 4.0f};
  REQUIRE(atacom::clip_grad_norm(g.data(), 2, 10.0) == Approx(5.0));
  REQUIRE(g[0] == 3.0f);
  REQUIRE(atacom::clip_grad_norm(g.data(), 2, 1.0) == Approx(5.0));
  REQUIRE(std::hypot(g[0], g[1]) == Approx(1.0).epsilon(1e-5));
  REQUIRE(atacom::clip_grad_norm(g.data(), 2, 0.0) == Approx(1.0).epsilon(1e-5));  // 0: off
  std::vector<float> tgt = {1.0f, 2.0f}, src = {3.0f, 6.0f};
  atacom::polyak_update(tgt.data(), src.data(), 2, 0.25);
  REQUIRE(tgt[0] == Approx(1.5f));
  REQUIRE(tgt[1] == Approx(3.0f));
}

TEST_CASE("adam: config JSON round trip, unknown keys rejected", "[adam]") {
  atacom::AdamConfig c = atacom::default_adam_config();
  c.beta2 = 0.99;
  nlohmann::json j = c;
  REQUIRE(j.get<atacom::AdamConfig>().beta2 == 0.99);
  j["beta3"] = 1;
  REQUIRE_THROWS_WITH(j.get<atacom::AdamConfig>(), Catch::Contains("adam.beta3"));
  REQUIRE_THROWS_WITH((nlohmann::json{{"beta1", 1.5}}.get<atacom::AdamConfig>()), Catch::Contains("beta1"));
}
