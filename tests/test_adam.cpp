#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <vector>

#include <Eigen/Core>

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

namespace {
// The fused step as it was written before it ran in chunks (commit
// b823ce0): eight Eigen array passes per block of 2^14. Its bits are the
// ones every committed run was trained with.
template <class T>
void fused_step_expr(T* p, T* g, T* m, T* v, T* target, int64_t n, int64_t t, double lr, double tau) {
  using A = Eigen::Array<T, Eigen::Dynamic, 1>;
  auto flush = [](auto& x) { x = (x.abs() < std::numeric_limits<T>::min()).select(T(0), x); };
  const atacom::AdamConfig cfg = atacom::default_adam_config();
  const T b1 = T(cfg.beta1), b2 = T(cfg.beta2), eps = T(cfg.eps);
  const T step_size = T(lr / (1.0 - std::pow(cfg.beta1, double(t))));
  const T inv_sqrt_bc2 = T(1.0 / std::sqrt(1.0 - std::pow(cfg.beta2, double(t))));
  const T ta = T(1.0 - tau), tb = T(tau);
  for (int64_t lo = 0; lo < n; lo += int64_t{1} << 14) {
    const Eigen::Index k = std::min<int64_t>(n - lo, int64_t{1} << 14);
    Eigen::Map<A> P(p + lo, k), M(m + lo, k), V(v + lo, k), G(g + lo, k);
    flush(G);
    M = b1 * M + (T(1) - b1) * G;
    V = b2 * V + (T(1) - b2) * G.square();
    flush(M);
    flush(V);
    P -= step_size * M / (V.sqrt() * inv_sqrt_bc2 + eps);
    G.setZero();
    if (target) {
      Eigen::Map<A> Tg(target + lo, k);
      Tg = ta * Tg + tb * P;
    }
  }
}

// Elements of x past the last 64-byte boundary.
template <class T>
size_t phase_of(const T* x) { return (reinterpret_cast<uintptr_t>(x) % 64) / sizeof(T); }

// A view into buf whose address is `elems` elements past a 64-byte boundary.
template <class T>
T* at_phase(std::vector<T>& buf, size_t elems) {
  const size_t per_line = 64 / sizeof(T);
  return buf.data() + (elems % per_line + per_line - phase_of(buf.data())) % per_line;
}

// A view into buf on the same 64-byte phase as like (up to 15 elements in).
template <class T>
T* same_phase(std::vector<T>& buf, const T* like) { return at_phase(buf, phase_of(like)); }

template <class T>
void check_fused_bits() {
  // The Eigen passes' bits depend on each array's 64-byte phase, so the
  // reference runs on arrays of the same phases as the tested ones. Phases:
  // all on the moments' phase (64-byte aligned); g one element off; p, g
  // and target aligned (SAC's layout); and p, g, target three phases apart.
  // Sizes cross chunk, block and packet boundaries; gradients reach below
  // the smallest normal.
  atacom::Rng r(7, 0);
  for (const int64_t n : {int64_t(5), int64_t(600), int64_t(40000), int64_t(3 * 16384 + 7)})
    for (int shift = 0; shift < 10; ++shift) {
      const bool with_target = shift % 2 == 0, mixed = shift >= 4 && shift < 6;
      const int fixed = shift >= 6 ? (shift >= 8 ? 2 : 1) : 0;  // 1: p, g, t aligned; 2: p, g, t on phases 3, 7, 11
      atacom::Adam<T> opt(size_t(n), atacom::default_adam_config());
      const T* m_like = opt.first_moment().data();
      std::vector<T> bp(size_t(n + 64)), bg(bp.size()), bt(bp.size()), rp(bp.size()), rg(bp.size()), rt(bp.size()),
          rm(bp.size(), T(0)), rv(bp.size(), T(0));
      // Tested side: p, g, target on m's phase plus (shift / 2) lines' worth
      // of whole elements, and g one element off when mixed.
      T* p = same_phase(bp, m_like) + shift / 2 * (64 / sizeof(T));
      T* g = same_phase(bg, m_like) + (mixed ? 1 : 0);
      T* t = same_phase(bt, m_like);
      if (fixed) {
        p = at_phase(bp, fixed == 1 ? 0 : 3);
        g = at_phase(bg, fixed == 1 ? 0 : 7);
        t = at_phase(bt, fixed == 1 ? 0 : 11);
      }
      T* p2 = same_phase(rp, p);
      T* g2 = same_phase(rg, g);
      T* t2 = same_phase(rt, t);
      T* m2 = same_phase(rm, m_like);
      T* v2 = same_phase(rv, opt.second_moment().data());
      for (int64_t i = 0; i < n; ++i) {
        p[i] = p2[i] = T(r.uniform(-1, 1));
        t[i] = t2[i] = T(r.uniform(-1, 1));
      }
      for (int step = 1; step <= 4; ++step) {
        for (int64_t i = 0; i < n; ++i) {
          const double e = std::exp(r.uniform(-100, 0));
          g[i] = g2[i] = i % 31 == 0 ? T(0) : i % 17 == 0 ? std::numeric_limits<T>::denorm_min() : T(r.uniform(-1, 1) * e);
        }
        opt.step_fused(p, g, 1e-3, with_target ? t : nullptr, 0.01);
        fused_step_expr(p2, g2, m2, v2, with_target ? t2 : nullptr, n, step, 1e-3, 0.01);
      }
      INFO("n " << n << " shift " << shift);
      const size_t bytes = size_t(n) * sizeof(T);
      CHECK(std::memcmp(p, p2, bytes) == 0);
      CHECK(std::memcmp(g, g2, bytes) == 0);
      CHECK(std::memcmp(t, t2, bytes) == 0);
      CHECK(std::memcmp(opt.first_moment().data(), m2, bytes) == 0);
      CHECK(std::memcmp(opt.second_moment().data(), v2, bytes) == 0);
    }
}

// The moments' phase does not reach the result: only the parameter pass
// (the one with the sqrt) differs between Eigen's scalar and packet paths,
// and its destination is p. So aligning the moments (Adam allocates them on
// 64 bytes) kept the bits of runs made when they started 16 bytes into a page.
template <class T>
void check_moment_phase_free() {
  const int64_t n = 3 * 16384 + 7;
  const size_t len = size_t(n + 64);
  std::vector<T> bp(len), bg(len), bt(len);
  std::vector<T> p_ref, t_ref, m_ref, v_ref;
  for (int mphase = 0; mphase < 16; mphase += 3) {
    std::vector<T> bm(len, T(0)), bv(len, T(0));
    atacom::Rng rr(11, 1);
    T* p = at_phase(bp, 0);
    T* g = at_phase(bg, 0);
    T* t = at_phase(bt, 0);
    T* m = at_phase(bm, size_t(mphase));
    T* v = at_phase(bv, size_t(mphase));
    // Parameters of the update's size: a last-bit change in the step shows in p.
    for (int64_t i = 0; i < n; ++i) p[i] = t[i] = T(rr.uniform(-1e-3, 1e-3));
    for (int step = 1; step <= 3; ++step) {
      for (int64_t i = 0; i < n; ++i)
        g[i] = i % 29 == 0 ? T(0) : T(rr.uniform(-1, 1) * std::exp(rr.uniform(i % 13 == 0 ? -90 : -10, 0)));
      fused_step_expr(p, g, m, v, t, n, step, 1e-3, 0.01);
    }
    if (p_ref.empty()) {
      p_ref.assign(p, p + n), t_ref.assign(t, t + n), m_ref.assign(m, m + n), v_ref.assign(v, v + n);
      continue;
    }
    INFO("moment phase " << mphase);
    const size_t bytes = size_t(n) * sizeof(T);
    CHECK(std::memcmp(p, p_ref.data(), bytes) == 0);
    CHECK(std::memcmp(t, t_ref.data(), bytes) == 0);
    CHECK(std::memcmp(m, m_ref.data(), bytes) == 0);
    CHECK(std::memcmp(v, v_ref.data(), bytes) == 0);
  }
}
}  // namespace

TEST_CASE("adam: the moments' 64-byte phase does not change the bits", "[adam]") {
  check_moment_phase_free<float>();
  check_moment_phase_free<double>();
}

TEST_CASE("adam: the chunked fused step has the bits of the whole-block Eigen passes, on every alignment", "[adam]") {
  check_fused_bits<float>();
  check_fused_bits<double>();
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
