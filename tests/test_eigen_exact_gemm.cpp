#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "atacom/rng.hpp"
#include "kernels/eigen_exact_gemm.hpp"
#include "train/tensor.hpp"

namespace {

using atacom::CMatMap;
using atacom::MatMap;

// Values with every sign, exact zeros of both signs, and subnormals, so
// that a different summation order or a missed FMA shows in the bits.
std::vector<float> data(size_t n, uint64_t seed) {
  atacom::Rng rng(seed, 7);
  std::vector<float> v(n);
  for (auto& x : v) {
    const double u = rng.uniform(0.0, 1.0);
    if (u < 0.05) x = 0.0f;
    else if (u < 0.07) x = -0.0f;
    else if (u < 0.08) x = float(rng.uniform(-1.0, 1.0)) * 1e-39f;
    else x = float(rng.normal() * std::exp(rng.uniform(-3.0, 3.0)));
  }
  return v;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

enum class Form { NN, TN, NT };

// One product in the form the tape runs it, both ways; returns whether the
// kernel took it. C has leading dimension ldc > n, so writes outside the
// tile would show too. With bias, the reference copies it into every row
// first (as the tape's fallback does) and the kernel starts from it.
bool check_product(Form f, int m, int n, int k, bool relu, uint64_t seed, bool bias = false) {
  const int ldc = n + 5, lda = (f == Form::TN ? m : k) + 3, ldb = (f == Form::NT ? k : n) + 2;
  const int arows = f == Form::TN ? k : m, brows = f == Form::NT ? n : k;
  const auto a = data(size_t(arows) * lda, seed), b = data(size_t(brows) * ldb, seed + 1);
  const auto c0 = data(size_t(m) * ldc, seed + 2);
  const auto bias_row = data(size_t(n), seed + 3);
  std::vector<float> ref = c0, got = c0;
  if (bias)
    for (int i = 0; i < m; ++i) std::memcpy(ref.data() + size_t(i) * ldc, bias_row.data(), sizeof(float) * size_t(n));
  MatMap<float> R(ref.data(), m, n, Eigen::OuterStride<>(ldc));
  const float* ap = a.data();
  const float* bp = b.data();
  int64_t a_rs = lda, a_cs = 1, b_rs = ldb, b_cs = 1;
  switch (f) {
    case Form::NN:
      R.noalias() += CMatMap<float>(ap, m, k, Eigen::OuterStride<>(lda)) * CMatMap<float>(bp, k, n, Eigen::OuterStride<>(ldb));
      break;
    case Form::TN:  // dW += X^T dY: A = X^T, X is (k x m)
      R.noalias() += CMatMap<float>(ap, k, m, Eigen::OuterStride<>(lda)).transpose() *
                     CMatMap<float>(bp, k, n, Eigen::OuterStride<>(ldb));
      a_rs = 1; a_cs = lda;
      break;
    case Form::NT:  // dX += dY W^T: B = W^T, W is (n x k)
      R.noalias() += CMatMap<float>(ap, m, k, Eigen::OuterStride<>(lda)) *
                     CMatMap<float>(bp, n, k, Eigen::OuterStride<>(ldb)).transpose();
      b_rs = 1; b_cs = ldb;
      break;
  }
  if (relu)
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j) {
        float& y = ref[size_t(i) * ldc + size_t(j)];
        y = y > 0.0f ? y : 0.0f;
      }
  const bool took = atacom::eigen_exact_gemm(m, n, k, ap, a_rs, a_cs, bp, b_rs, b_cs, got.data(), ldc,
                                             bias ? bias_row.data() : nullptr, relu);
  const std::string what = "form " + std::to_string(int(f)) + " m " + std::to_string(m) + " n " + std::to_string(n) +
                           " k " + std::to_string(k) + (relu ? " relu" : "") + (bias ? " bias" : "");
  INFO(what);
  if (took) REQUIRE(same_bits(got, ref));
  else REQUIRE(same_bits(got, c0));  // declined: nothing touched
  return took;
}

}  // namespace

TEST_CASE("eigen exact gemm: the bits of Eigen's product wherever it takes one", "[gemm]") {
  uint64_t seed = 1;
  int taken = 0, tried = 0;
  for (Form f : {Form::NN, Form::TN, Form::NT})
    for (int m : {2, 3, 5, 8, 13, 61, 64, 256})
      for (int n : {16, 32, 48, 80, 96, 112, 128, 256})
        for (int k : {1, 3, 14, 20, 27, 64, 256, 300, 1024}) {
          ++tried;
          taken += check_product(f, m, n, k, (seed & 1) != 0, seed, seed % 3 == 0) ? 1 : 0;
          seed += 3;
        }
  INFO("took " << taken << " of " << tried);
#if defined(EIGEN_VECTORIZE_AVX512)
  CHECK(taken > tried / 4);
#else
  CHECK(taken == 0);
#endif
}

TEST_CASE("eigen exact gemm: takes the tape's hot tiles on AVX-512 builds", "[gemm]") {
#if defined(EIGEN_VECTORIZE_AVX512)
  // The SAC update's 128-column tiles: forward (64 x 128, depth 20/27/256),
  // dW (256 or 27 x 128, depth 64), dX (64 x 128, depth 256).
  CHECK(check_product(Form::NN, 64, 128, 256, true, 11, true));
  CHECK(check_product(Form::NN, 64, 128, 27, true, 12, true));
  CHECK(check_product(Form::TN, 256, 128, 64, false, 13));
  CHECK(check_product(Form::TN, 27, 128, 64, false, 14));
  CHECK(check_product(Form::NT, 64, 128, 256, false, 15));
#else
  SUCCEED("no AVX-512 in this build: the tape runs Eigen's products");
#endif
}

TEST_CASE("eigen exact gemm: declines what Eigen runs another way", "[gemm]") {
  std::vector<float> a(64 * 64, 1.0f), b(64 * 64, 1.0f), c(64 * 64, 2.0f);
  const auto c0 = c;
  // One row or column of C (GEMV), a width Eigen covers with 16-row panels,
  // a tiny product, and a B that is neither row-major nor transposed.
  CHECK_FALSE(atacom::eigen_exact_gemm(1, 32, 64, a.data(), 64, 1, b.data(), 64, 1, c.data(), 64, nullptr, false));
  CHECK_FALSE(atacom::eigen_exact_gemm(64, 16, 64, a.data(), 64, 1, b.data(), 64, 1, c.data(), 64, nullptr, false));
  CHECK_FALSE(atacom::eigen_exact_gemm(2, 16, 1, a.data(), 64, 1, b.data(), 64, 1, c.data(), 64, nullptr, false));
  CHECK_FALSE(atacom::eigen_exact_gemm(8, 32, 8, a.data(), 64, 1, b.data(), 2, 2, c.data(), 64, nullptr, false));
  CHECK(same_bits(c, c0));
}
