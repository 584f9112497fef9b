#include "kernels/eigen_exact_gemm.hpp"

#include <algorithm>

#include <Eigen/Core>

#if defined(EIGEN_VECTORIZE_AVX512)
#include <immintrin.h>
#endif

namespace atacom {

#if defined(EIGEN_VECTORIZE_AVX512)
namespace {

using Eigen::Index;
using Traits = Eigen::internal::gebp_traits<float, float>;
// The panel shapes the exactness argument is about (header comment).
static_assert(Traits::mr == 48 && Traits::nr == 4 && Traits::LhsProgress == 16,
              "Eigen's float GEBP panels are not the ones this kernel reproduces");

// Depth of one transposed strip on the stack: 512 x 48 floats = 96 KB.
constexpr Index kMaxStripDepth = 512;

// One MR x (16 NP) block of C over kd steps of k: accumulators from zero,
// one FMA per step in k order, then C + acc (Eigen's pmadd(acc, 1, C)),
// where C is read from init (one row for all) when given.
template <int MR, int NP>
inline void micro(int kd, const float* a, int64_t a_rs, int64_t a_cs, const float* b, int64_t ldb, float* c,
                  int64_t ldc, const float* init, bool relu) {
  __m512 acc[MR][NP];
  for (int r = 0; r < MR; ++r)
    for (int q = 0; q < NP; ++q) acc[r][q] = _mm512_setzero_ps();
  for (int p = 0; p < kd; ++p) {
    __m512 bv[NP];
    for (int q = 0; q < NP; ++q) bv[q] = _mm512_loadu_ps(b + p * ldb + 16 * q);
    for (int r = 0; r < MR; ++r) {
      const __m512 av = _mm512_set1_ps(a[r * a_rs + p * a_cs]);
      for (int q = 0; q < NP; ++q) acc[r][q] = _mm512_fmadd_ps(av, bv[q], acc[r][q]);
    }
  }
  const __m512 zero = _mm512_setzero_ps();
  for (int r = 0; r < MR; ++r)
    for (int q = 0; q < NP; ++q) {
      float* cp = c + r * ldc + 16 * q;
      __m512 v = _mm512_add_ps(_mm512_loadu_ps(init ? init + 16 * q : cp), acc[r][q]);
      // max(v, 0) returns its second operand for NaN and for -0: the bits of v > 0 ? v : 0.
      if (relu) v = _mm512_max_ps(v, zero);
      _mm512_storeu_ps(cp, v);
    }
}

template <int NP>
void strip(int m, int kd, const float* a, int64_t a_rs, int64_t a_cs, const float* b, int64_t ldb, float* c,
           int64_t ldc, const float* init, bool relu) {
  int i = 0;
  for (; i + 8 <= m; i += 8) micro<8, NP>(kd, a + i * a_rs, a_rs, a_cs, b, ldb, c + i * ldc, ldc, init, relu);
  for (; i + 4 <= m; i += 4) micro<4, NP>(kd, a + i * a_rs, a_rs, a_cs, b, ldb, c + i * ldc, ldc, init, relu);
  for (; i < m; ++i) micro<1, NP>(kd, a + i * a_rs, a_rs, a_cs, b, ldb, c + i * ldc, ldc, init, relu);
}

// Eigen's PacketBlock of __m512 drops the vector type's alignment attribute
// in the template argument (harmless: the block lives in registers).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"
// dst (kd x w, row-major) = the k-range [0, kd) of w rows of a row-major
// source (row j at src + j * ld), transposed; 16 x 16 blocks in registers.
void transpose_strip(const float* src, int64_t ld, int kd, int w, float* dst) {
  int p = 0;
  for (; p + 16 <= kd; p += 16)
    for (int j = 0; j < w; j += 16) {
      Eigen::internal::PacketBlock<Eigen::internal::Packet16f, 16> blk;
      for (int r = 0; r < 16; ++r) blk.packet[r] = _mm512_loadu_ps(src + (j + r) * ld + p);
      Eigen::internal::ptranspose(blk);
      for (int r = 0; r < 16; ++r) _mm512_storeu_ps(dst + (p + r) * w + j, blk.packet[r]);
    }
  for (; p < kd; ++p)
    for (int j = 0; j < w; ++j) dst[p * w + j] = src[j * ld + p];
}
#pragma GCC diagnostic pop

// C += A B in Eigen's depth blocks, 48-column strips of C at a time.
template <bool Transposed>
void run(int m, int n, int k, int kc, const float* a, int64_t a_rs, int64_t a_cs, const float* b, int64_t b_rs,
         int64_t b_cs, float* c, int64_t ldc, const float* c_init, bool relu) {
  // A transposed B is copied strip by strip; a row-major one is read in place.
  alignas(64) float panel[Transposed ? kMaxStripDepth * 48 : 1];
  for (int k0 = 0; k0 < k; k0 += kc) {
    const int kd = std::min(kc, k - k0);
    const bool last = k0 + kd == k;
    const float* init = k0 == 0 ? c_init : nullptr;  // later depth blocks add to C
    const float* ak = a + k0 * a_cs;
    for (int j0 = 0; j0 < n;) {
      const int w = n - j0 >= 48 ? 48 : n - j0 >= 32 ? 32 : 16;  // n is a multiple of 16 here
      const float* bs = b + k0 * b_rs + j0 * b_cs;
      int64_t ldb = b_rs;
      if constexpr (Transposed) {
        transpose_strip(bs, b_cs, kd, w, panel);
        bs = panel;
        ldb = w;
      }
      float* cs = c + j0;
      const float* is = init ? init + j0 : nullptr;
      if (w == 48) strip<3>(m, kd, ak, a_rs, a_cs, bs, ldb, cs, ldc, is, relu && last);
      else if (w == 32) strip<2>(m, kd, ak, a_rs, a_cs, bs, ldb, cs, ldc, is, relu && last);
      else strip<1>(m, kd, ak, a_rs, a_cs, bs, ldb, cs, ldc, is, relu && last);
      j0 += w;
    }
  }
}

// Rows of C^T in one of Eigen's blocks that its 48- and 32-row panels cover whole.
bool sequential_panels(Index rows) { return rows % 48 == 0 || rows % 48 == 32; }

}  // namespace
#endif

bool eigen_exact_gemm(int m, int n, int k, const float* a, int64_t a_rs, int64_t a_cs, const float* b, int64_t b_rs,
                      int64_t b_cs, float* c, int64_t ldc, const float* c_init, bool relu) {
#if defined(EIGEN_VECTORIZE_AVX512)
  // Eigen's dispatch: tiny products go coefficient-wise, a single row or
  // column of C goes to GEMV; neither is this kernel.
  if (m < 2 || n < 2 || k < 1 || m + n + k < EIGEN_GEMM_TO_COEFFBASED_THRESHOLD) return false;
  if (b_cs != 1 && b_rs != 1) return false;
  // The blocking Eigen computes for this product (its kernel sees C^T: rows
  // n, columns m, depth k), from the same function and cache sizes.
  Index kc = k, mc = n, nc = m;
  Eigen::internal::computeProductBlockingSizes<float, float, 1>(kc, mc, nc, Index(1));
  if (!sequential_panels(std::min<Index>(mc, n)) || (n % mc != 0 && !sequential_panels(n % mc))) return false;
  if (b_cs != 1 && kc > kMaxStripDepth) return false;
  if (b_cs == 1) run<false>(m, n, k, int(kc), a, a_rs, a_cs, b, b_rs, b_cs, c, ldc, c_init, relu);
  else run<true>(m, n, k, int(kc), a, a_rs, a_cs, b, b_rs, b_cs, c, ldc, c_init, relu);
  return true;
#else
  (void)m; (void)n; (void)k; (void)a; (void)a_rs; (void)a_cs; (void)b; (void)b_rs; (void)b_cs; (void)c; (void)ldc;
  (void)c_init; (void)relu;
  return false;
#endif
}

}  // namespace atacom
