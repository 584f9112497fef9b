// SIMD across envs: a "lane block" holds kLanes envs, one per vector lane.
//
// Internal to kernels/: GCC vector extensions, so kernel code reads like
// scalar code and compiles to AVX-512 (8 doubles) with -march=native, or to
// narrower vectors elsewhere. Every operation is a plain IEEE double
// operation per lane (no FMA contraction in ISO mode, no fast-math), so a lane
// computes bit-for-bit what the same expression computes on a double.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace atacom::lanes {

constexpr int kLanes = 8;
typedef double vd __attribute__((vector_size(kLanes * sizeof(double))));
typedef int64_t vm __attribute__((vector_size(kLanes * sizeof(int64_t))));  // lane masks (-1 / 0)

// Unaligned whole-vector load/store (a 64-byte memcpy would be split into
// 256-bit moves through the stack, which defeats store-to-load forwarding).
typedef double vd_unaligned __attribute__((vector_size(kLanes * sizeof(double)), aligned(alignof(double))));
static inline vd load(const double* p) { return *reinterpret_cast<const vd_unaligned*>(p); }
static inline void store(double* p, vd v) { *reinterpret_cast<vd_unaligned*>(p) = v; }

static inline vd splat(double x) { return vd{} + x; }
static inline vd vmin(vd a, vd b) { return a < b ? a : b; }
static inline vd vmax(vd a, vd b) { return a > b ? a : b; }
static inline vd vabs(vd a) { return a < 0.0 ? -a : a; }
static inline vd vsel(vm m, vd a, vd b) { return m ? a : b; }
static inline vd vclamp(vd x, double lo, double hi) { return vmin(vmax(x, splat(lo)), splat(hi)); }
static inline vd vsqrt(vd x) {
#if defined(__AVX512F__)
  return (vd)_mm512_maskz_sqrt_pd(0xFF, (__m512d)x);  // correctly rounded, same as std::sqrt per lane
#else
  vd r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
#endif
}
static inline vm vfinite(vd x) { return (x - x) == 0.0; }  // false for NaN and +-Inf

// 1 / x for finite x > 0 (slack rates, R's diagonal). With AVX-512: the
// 14-bit estimate refined by two Newton steps (relative error ~2^-56, at
// most 1 ulp from the division) at a third of vdivpd's throughput cost,
// which otherwise dominates the row pass.
static inline vd vrecip(vd x) {
#if defined(__AVX512F__)
  vd r = (vd)_mm512_maskz_rcp14_pd(0xFF, (__m512d)x);  // maskz: no undefined passthrough (GCC 12 warns)
  r = r * (2.0 - x * r);
  r = r * (2.0 - x * r);
  return r;
#else
  return 1.0 / x;
#endif
}

// exp(x) with a degree-13 Taylor polynomial after range reduction to
// |r| <= ln2/2: relative error below 2e-16 (std::exp stays a scalar libm
// call). Arguments are clamped to [-708, 709]; callers cap the result anyway.
static inline vd vexp(vd x) {
  x = vmin(vmax(x, splat(-708.0)), splat(709.0));
  const double kLog2e = 1.4426950408889634;
  const double kLn2Hi = 6.93147180369123816490e-01;
  const double kLn2Lo = 1.90821492927058770002e-10;
  const double kShift = 6755399441055744.0;  // 1.5 * 2^52: round to nearest
  const vd t = x * kLog2e + kShift;
  const vd nf = t - kShift;
  const vd r = (x - nf * kLn2Hi) - nf * kLn2Lo;
  vd p = splat(1.0 / 6227020800.0);
  p = p * r + 1.0 / 479001600.0;
  p = p * r + 1.0 / 39916800.0;
  p = p * r + 1.0 / 3628800.0;
  p = p * r + 1.0 / 362880.0;
  p = p * r + 1.0 / 40320.0;
  p = p * r + 1.0 / 5040.0;
  p = p * r + 1.0 / 720.0;
  p = p * r + 1.0 / 120.0;
  p = p * r + 1.0 / 24.0;
  p = p * r + 1.0 / 6.0;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  // 2^n through the exponent bits; n in [-1021, 1023] after the clamp.
  const vm n = (vm)t - (vm)splat(kShift);
  const vd scale = (vd)((n + 1023) << 52);
  return p * scale;
}

static inline bool any(vm m) {
  int64_t acc = 0;
  for (int l = 0; l < kLanes; ++l) acc |= m[l];
  return acc != 0;
}

// sin and cos of every lane, accurate to a few ulp for |x| < 1e5.
// Range reduction by k = round(x / (pi/2)) with pi/2 split into three parts
// (each product k * part is exact), then Taylor series to degree 17/18 on
// |r| <= pi/4 (truncation error < 1e-19) and quadrant selection.
static inline void vsincos(vd x, vd& s, vd& c) {
  constexpr double kTwoOverPi = 0.6366197723675814;
  constexpr double kPio2Hi = 1.5707963705062866;       // float-rounded pi/2
  constexpr double kPio2Mid = -4.371138828673793e-08;  // float-rounded remainder
  constexpr double kPio2Lo = -1.7151244994428829e-15;  // rest
  constexpr double kRound = 6755399441055744.0;        // 1.5 * 2^52: x + kRound - kRound rounds to an integer
  const vd kf = (x * kTwoOverPi + kRound) - kRound;
  const vd r = ((x - kf * kPio2Hi) - kf * kPio2Mid) - kf * kPio2Lo;
  const vm k = __builtin_convertvector(kf, vm);
  const vd r2 = r * r;
  // 1/n! for the odd and even powers.
  const vd ps = r + r * r2 *
      (-1.0 / 6 + r2 * (1.0 / 120 + r2 * (-1.0 / 5040 + r2 * (1.0 / 362880 + r2 * (-1.0 / 39916800 +
      r2 * (1.0 / 6227020800.0 + r2 * (-1.0 / 1307674368000.0 + r2 * (1.0 / 355687428096000.0))))))));
  const vd pc = 1.0 + r2 *
      (-0.5 + r2 * (1.0 / 24 + r2 * (-1.0 / 720 + r2 * (1.0 / 40320 + r2 * (-1.0 / 3628800 +
      r2 * (1.0 / 479001600.0 + r2 * (-1.0 / 87178291200.0 + r2 * (1.0 / 20922789888000.0 +
      r2 * (-1.0 / 6402373705728000.0)))))))));
  const vm odd = (k & 1) != 0;
  vd ss = vsel(odd, pc, ps);
  vd cc = vsel(odd, ps, pc);
  ss = vsel((k & 2) != 0, -ss, ss);
  cc = vsel(((k + 1) & 2) != 0, -cc, cc);
  s = ss;
  c = cc;
}

// Gather lane l of a lane array from/to row-major per-env storage.
static inline vd load_strided(const double* base, int stride, int count) {
  vd v = vd{};
  for (int l = 0; l < kLanes; ++l) v[l] = base[(l < count ? l : count - 1) * stride];
  return v;
}

#if defined(__AVX512F__)
static_assert(kLanes == 8);
// GCC 12 flags its own _mm512_undefined_pd inside the unpack intrinsics.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
// In-register 8 x 8 transpose of doubles: pairs, then 128-bit blocks, then
// 256-bit halves (24 shuffles). Its own inverse.
static inline void transpose8x8(__m512d r[8]) {
  const __m512d t0 = _mm512_unpacklo_pd(r[0], r[1]), t1 = _mm512_unpackhi_pd(r[0], r[1]);
  const __m512d t2 = _mm512_unpacklo_pd(r[2], r[3]), t3 = _mm512_unpackhi_pd(r[2], r[3]);
  const __m512d t4 = _mm512_unpacklo_pd(r[4], r[5]), t5 = _mm512_unpackhi_pd(r[4], r[5]);
  const __m512d t6 = _mm512_unpacklo_pd(r[6], r[7]), t7 = _mm512_unpackhi_pd(r[6], r[7]);
  const __m512d u0 = _mm512_shuffle_f64x2(t0, t2, 0x88), u1 = _mm512_shuffle_f64x2(t1, t3, 0x88);
  const __m512d u2 = _mm512_shuffle_f64x2(t0, t2, 0xDD), u3 = _mm512_shuffle_f64x2(t1, t3, 0xDD);
  const __m512d u4 = _mm512_shuffle_f64x2(t4, t6, 0x88), u5 = _mm512_shuffle_f64x2(t5, t7, 0x88);
  const __m512d u6 = _mm512_shuffle_f64x2(t4, t6, 0xDD), u7 = _mm512_shuffle_f64x2(t5, t7, 0xDD);
  r[0] = _mm512_shuffle_f64x2(u0, u4, 0x88);
  r[1] = _mm512_shuffle_f64x2(u1, u5, 0x88);
  r[2] = _mm512_shuffle_f64x2(u2, u6, 0x88);
  r[3] = _mm512_shuffle_f64x2(u3, u7, 0x88);
  r[4] = _mm512_shuffle_f64x2(u0, u4, 0xDD);
  r[5] = _mm512_shuffle_f64x2(u1, u5, 0xDD);
  r[6] = _mm512_shuffle_f64x2(u2, u6, 0xDD);
  r[7] = _mm512_shuffle_f64x2(u3, u7, 0xDD);
}
#pragma GCC diagnostic pop
#endif

// dst[idx][l] = src[l][idx] for idx < count: `count` consecutive doubles of
// each lane's env into lane vectors. With AVX-512, 8 x 8 tiles are
// transposed in registers (8 loads, 24 shuffles, 8 stores instead of 64
// scalar moves); the last partial tile with masked loads (the masked-off
// elements are never read, so no access past src[l] + count).
static inline void gather_rows(const double* const src[kLanes], int count, vd* dst) {
#if defined(__AVX512F__)
  for (int idx = 0; idx < count; idx += 8) {
    const int t = count - idx < 8 ? count - idx : 8;
    const __mmask8 mask = static_cast<__mmask8>((1u << t) - 1u);
    __m512d r[8];
    for (int l = 0; l < 8; ++l) r[l] = _mm512_maskz_loadu_pd(mask, src[l] + idx);
    transpose8x8(r);
    for (int q = 0; q < t; ++q) dst[idx + q] = (vd)r[q];
  }
#else
  for (int idx = 0; idx < count; ++idx)
    for (int l = 0; l < kLanes; ++l) dst[idx][l] = src[l][idx];
#endif
}

// Inverse of gather_rows: dst[l][idx] = src[idx][l] for idx < count.
static inline void scatter_rows(const vd* src, int count, double* const dst[kLanes]) {
  int idx = 0;
#if defined(__AVX512F__)
  for (; idx + 8 <= count; idx += 8) {
    __m512d r[8];
    for (int l = 0; l < 8; ++l) r[l] = (__m512d)src[idx + l];
    transpose8x8(r);
    for (int l = 0; l < 8; ++l) _mm512_storeu_pd(dst[l] + idx, r[l]);
  }
#endif
  for (; idx < count; ++idx)
    for (int l = 0; l < kLanes; ++l) dst[l][idx] = src[idx][l];
}
}  // namespace atacom::lanes
