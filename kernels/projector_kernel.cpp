// Batched ATACOM projector.
//
// Fast path (inequality rows): blocks of kLanes envs are
// transposed into lane-major scratch (element-major, env-minor) so that every
// arithmetic loop runs over the lanes and vectorises without intrinsics. The
// (k x k) system of the paper is never formed; with J_G = J_q G and
// W = A^-2 the push-through identity gives
//   N_a = (I + J_G^T W J_G)^-1,   b = -N_a J_G^T W r,   r = F + K_c cbar,
// and the slack controls follow from the constraint rows themselves:
//   u_s = -A^-1 (r + J_G a)   (so J_u [a; u_s] = -r holds for any lambda).
// I + J_G^T W J_G = R^T R comes from a Householder QR of [I_m; A^-1 J_G]
// rather than from forming the product, which would square the condition
// number (W reaches 1/tol^2 on active rows). Cost per env, in multiply-adds:
//   k n m (J_G, dense G) + k m (m + 1) (QR and rhs) + k n (u_s = -A^-1 (r +
//   J_q (G a)), so J_G is never stored) + O(n m + m^2).
//
// Smooth basis (no equality rows): the same lane kernel, plus N_a^{1/2} from
// a per-lane cyclic Jacobi eigen-decomposition of N_a = R^-1 R^-T.
//
// General path (equality rows): the same m x m algebra per env with Eigen,
// plus the k_e x k_e Schur complement of the equality rows and, for the
// smooth basis, N_a^{1/2} (the action block of the Procrustes basis).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <type_traits>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <Eigen/Dense>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "kernels/lanes.hpp"

namespace atacom {

namespace {

constexpr int kLanes = 8;        // one AVX-512 register of doubles
constexpr int kBlockEnvs = 256;  // envs per parallel task (thread-count independent)

// One lane vector: 8 envs' values of one element. GCC lowers arithmetic on
// it to one AVX-512 instruction (or two AVX2 ones); writing the kernel in
// this type, rather than in loops the vectoriser may reorder, pins the
// vectorisation to the env dimension.
typedef double V __attribute__((vector_size(kLanes * sizeof(double))));
typedef long long VI __attribute__((vector_size(kLanes * sizeof(double))));

inline V splat(double x) { return V{} + x; }
inline V vmin(V a, V b) { return a < b ? a : b; }
inline V vmax(V a, V b) { return a > b ? a : b; }
inline VI vfinite(V x) { return (x - x) == 0.0; }  // false for NaN and +-Inf
inline V vsqrt(V x) {
  V r;  // GCC turns this into one vsqrtpd (sqrt cannot set errno here: -fno-math-errno)
  for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
}

// 1 / x for finite x > 0 (slack rates, R's diagonal). With AVX-512: the
// 14-bit estimate refined by two Newton steps (relative error ~2^-56, at
// most 1 ulp from the division) at a third of vdivpd's throughput cost,
// which otherwise dominates the row pass.
inline V vrecip(V x) {
#if defined(__AVX512F__)
  V r = (V)_mm512_maskz_rcp14_pd(0xFF, (__m512d)x);  // maskz: no undefined passthrough (GCC 12 warns)
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
inline V vexp(V x) {
  x = vmin(vmax(x, splat(-708.0)), splat(709.0));
  const double kLog2e = 1.4426950408889634;
  const double kLn2Hi = 6.93147180369123816490e-01;
  const double kLn2Lo = 1.90821492927058770002e-10;
  const double kShift = 6755399441055744.0;  // 1.5 * 2^52: round to nearest
  const V t = x * kLog2e + kShift;
  const V nf = t - kShift;
  const V r = (x - nf * kLn2Hi) - nf * kLn2Lo;
  V p = splat(1.0 / 6227020800.0);
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
  const VI n = (VI)t - (VI)splat(kShift);
  const V scale = (V)((n + 1023) << 52);
  return p * scale;
}

inline bool finite(double x) { return std::isfinite(x); }

// Software prefetch of a later block's inputs into L2, a few cache lines at a
// time while the current block computes. At large N the batch streams from
// DRAM; issuing all the lines at once would stall on the miss buffers, and
// the hardware prefetcher alone leaves the gathers waiting on memory.
struct NextBlockPrefetch {
  static constexpr int kMaxRanges = 6;
  const char* ptr[kMaxRanges];
  const char* end[kMaxRanges];
  int count = 0, cur = 0;

  void add(const double* base, size_t begin_elem, size_t end_elem) {
    if (end_elem <= begin_elem || count == kMaxRanges) return;
    ptr[count] = reinterpret_cast<const char*>(base + begin_elem);
    end[count] = reinterpret_cast<const char*>(base + end_elem);
    ++count;
  }
  // Prefetch up to `lines` more cache lines.
  void step(int lines) {
    while (lines > 0 && cur < count) {
      if (ptr[cur] >= end[cur]) { ++cur; continue; }
      __builtin_prefetch(ptr[cur], 0, 2);
      ptr[cur] += 64;
      --lines;
    }
  }
};

// Lane-major scratch for one block; sized once per thread and model shape.
// Every array is (elements) lane vectors: element-major, env-minor.
struct LaneScratch {
  std::unique_ptr<V[]> buf;
  int n = -1, m = -1, k = -1, p = -1;
  V* JqT;   // (k x n)  J_q
  V* JxT;   // (k x p)  J_x
  V* GT;    // (n x m)  G (dense) or (n) diagonal
  V* fT;    // (n)      f
  V* xdT;   // (p)      xdot
  V* JG;    // (k x m)  J_G = J_q G, row-major (only diagonal G without drift)
  V* Ga;    // (n)      G a
  V* Bw;    // (k x m)  A^-1 J_G; overwritten by the QR
  V* inv;   // (k)      1 / slack rate
  V* c;     // (k)      constraint values
  V* s;     // (k)      slack values
  V* y;     // (k)      A^-1 r; overwritten by the QR, then the slack controls
  V* y0;    // (k)      A^-1 r, kept for the slack controls
  V* R;     // (m x m)  upper triangular factor, row-major
  V* Rd;    // (m)      1 / diag(R)
  V* z;     // (m)      top of Q^T [0; y]
  V* alpha; // (m)
  V* b;     // (m)      -N_a J_G^T W r
  V* t;     // (m)      N_a alpha
  V* a;     // (m)      safe control
  V* Am;    // (m x m)  smooth basis: N_a, rotated to diagonal by Jacobi
  V* Vm;    // (m x m)  smooth basis: eigenvectors of N_a (columns)

  void setup(const ProjectorModel& mod) {
    if (mod.n == n && mod.m == m && mod.k == k && mod.p == p) return;
    n = mod.n; m = mod.m; k = mod.k; p = mod.p;
    const size_t sizes[] = {size_t(k) * n, size_t(k) * p, size_t(n) * m, size_t(n), size_t(p),
                            size_t(k) * m, size_t(n), size_t(k) * m, size_t(k), size_t(k), size_t(k), size_t(k),
                            size_t(k), size_t(m) * m, size_t(m), size_t(m), size_t(m), size_t(m), size_t(m), size_t(m),
                            size_t(m) * m, size_t(m) * m};
    V** fields[] = {&JqT, &JxT, &GT, &fT, &xdT, &JG, &Ga, &Bw, &inv, &c, &s, &y, &y0, &R, &Rd, &z, &alpha, &b, &t, &a, &Am, &Vm};
    static_assert(std::size(sizes) == std::size(fields));
    size_t total = 0;
    for (size_t sz : sizes) total += sz;
    buf.reset(new V[total + 1]());  // aligned new: V is 64-byte aligned
    V* ptr = buf.get();
    for (size_t i = 0; i < std::size(fields); ++i) {
      *fields[i] = ptr;
      ptr += sizes[i];
    }
  }
};

// Env-major inputs to lane vectors and back: kernels/lanes.hpp's 8 x 8
// register transposes (V is the same vector type as lanes::vd).
static_assert(std::is_same_v<V, lanes::vd> && kLanes == lanes::kLanes);
inline void gather_lanes(const double* const src[kLanes], int count, V* dst) { lanes::gather_rows(src, count, dst); }
inline void scatter_lanes(const V* src, int count, double* const dst[kLanes]) { lanes::scatter_rows(src, count, dst); }

// Fast path over envs [lo, hi), hi - lo <= kLanes. MC is m when it is a
// compile-time constant (loops over m then unroll), 0 otherwise.
template <int MC>
void project_lanes(const ProjectorModel& mod, ProjectorBatch& B, int lo, int hi, LaneScratch& S, bool store_basis,
                   bool store_slack) {
  constexpr int L = kLanes;
  const int m = MC > 0 ? MC : mod.m;
  constexpr int MA = MC > 0 ? MC : 16;  // accumulator capacity
  const int n = mod.n, k = mod.k, p = mod.p;
  const bool diagG = mod.g_form == GForm::Diagonal;
  const bool need_JqT = !diagG || mod.has_drift;
  const int gsz = diagG ? n : n * m;

  // ---- gather: env-major inputs -> lane vectors. Idle lanes repeat the last env.
  const double* src[L];
  auto lane_env = [&](int l) { return size_t(std::min(lo + l, hi - 1)); };
  if (need_JqT) {
    for (int l = 0; l < L; ++l) src[l] = B.Jq.data() + lane_env(l) * k * n;
    gather_lanes(src, k * n, S.JqT);
  }
  for (int l = 0; l < L; ++l) src[l] = B.G.data() + lane_env(l) * gsz;
  gather_lanes(src, gsz, S.GT);
  if (diagG && !need_JqT) {
    // J_G = J_q diag(g): without drift the Jacobian itself is only needed scaled.
    for (int l = 0; l < L; ++l) src[l] = B.Jq.data() + lane_env(l) * k * n;
    gather_lanes(src, k * n, S.JG);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < m; ++j) S.JG[i * m + j] *= S.GT[j];
  }
  if (mod.has_drift) {
    for (int l = 0; l < L; ++l) src[l] = B.f.data() + lane_env(l) * n;
    gather_lanes(src, n, S.fT);
  }
  if (p > 0) {
    for (int l = 0; l < L; ++l) src[l] = B.Jx.data() + lane_env(l) * k * p;
    gather_lanes(src, k * p, S.JxT);
    for (int l = 0; l < L; ++l) src[l] = B.xdot.data() + lane_env(l) * p;
    gather_lanes(src, p, S.xdT);
  }
  for (int l = 0; l < L; ++l) src[l] = B.c.data() + lane_env(l) * k;
  gather_lanes(src, k, S.c);
  for (int l = 0; l < L; ++l) src[l] = B.alpha.data() + lane_env(l) * m;
  gather_lanes(src, m, S.alpha);

  // Prefetch envs [hi + L, hi + 2 L) (two blocks ahead hides DRAM latency
  // best), spread over this block's constraint rows. Only when the batch's
  // inputs exceed the L2 cache (1 MiB): in cache the prefetches are pure
  // overhead (~10% at N = 128), from DRAM they gain 10-20%.
  NextBlockPrefetch pf;
  int pf_per_row = 0;
  const size_t env_doubles = size_t(k) * (n + p) + gsz + n + k + m;  // f counted as n even without drift
  if (size_t(B.N) * env_doubles * sizeof(double) > (size_t(1) << 20)) {
    const size_t e0 = size_t(std::min(hi + L, B.N)), e1 = size_t(std::min(hi + 2 * L, B.N));
    pf.add(B.Jq.data(), e0 * k * n, e1 * k * n);
    pf.add(B.G.data(), e0 * gsz, e1 * gsz);
    if (mod.has_drift) pf.add(B.f.data(), e0 * n, e1 * n);
    pf.add(B.c.data(), e0 * k, e1 * k);
    pf.add(B.alpha.data(), e0 * m, e1 * m);
    if (p > 0) pf.add(B.Jx.data(), e0 * k * p, e1 * k * p);
    const size_t lines = size_t(L) * sizeof(double) * env_doubles / 64 + 6;
    pf_per_row = int(lines / size_t(std::max(k, 1))) + 1;
  }

  // ---- alpha: NaN/Inf -> 0 (flagged), then clip to [-1, 1].
  VI alpha_bad = VI{};
  for (int j = 0; j < m; ++j) {
    const VI fin = vfinite(S.alpha[j]);
    alpha_bad |= ~fin;
    S.alpha[j] = vmin(vmax(fin ? S.alpha[j] : V{}, splat(-1.0)), splat(1.0));
  }

  // ---- per row: slack, rate, J_G row, F, r = F + K_c cbar, B = A^-1 J_G
  // and y = A^-1 r. The same pass accumulates what the first Householder
  // reflection needs: the squared norm of [1; B(:, 0)] and the dot products
  // of B(:, 0) with the other columns and with y (see the QR below).
  // J_G itself is only kept when J_q is not (diagonal G without drift).
  const double Kc = mod.K_c;
  V nrm = splat(1.0);
  V dot[MA + 1];  // dot[cc] = B(:, j)^T B(:, j + 1 + cc); dot[w] = B(:, j)^T y
#pragma GCC unroll 16
  for (int cc = 0; cc < m; ++cc) dot[cc] = V{};
  for (int i = 0; i < k; ++i) {
    const double tol = mod.tol[i], beta = mod.beta[i];
    const V c = S.c[i];
    const V s = vmax(-c, splat(tol));
    S.s[i] = s;
    V rate;
    switch (mod.slack[i]) {
      case SlackType::SoftCorner: rate = vmin(vexp(beta * s), splat(1.0 / tol)) - 1.0; break;
      case SlackType::Exponential: rate = beta * s; break;
      default: rate = vsqrt(2.0 * s); break;  // Quadratic
    }
    const V inv = vrecip(rate);
    S.inv[i] = inv;
    pf.step(pf_per_row);
    V jg[MA];
    if (!diagG) {
#pragma GCC unroll 16
      for (int j = 0; j < m; ++j) jg[j] = V{};
      for (int t = 0; t < n; ++t) {
        const V jq = S.JqT[i * n + t];
        const V* gt = S.GT + size_t(t) * m;
#pragma GCC unroll 16
        for (int j = 0; j < m; ++j) jg[j] += jq * gt[j];
      }
    } else if (need_JqT) {
#pragma GCC unroll 16
      for (int j = 0; j < m; ++j) jg[j] = S.JqT[i * n + j] * S.GT[j];
    } else {
#pragma GCC unroll 16
      for (int j = 0; j < m; ++j) jg[j] = S.JG[i * m + j];
    }
    V F = V{};
    if (mod.has_drift)
      for (int t = 0; t < n; ++t) F += S.JqT[i * n + t] * S.fT[t];
    for (int t = 0; t < p; ++t) F += S.JxT[i * p + t] * S.xdT[t];
    V* bw = S.Bw + size_t(i) * m;
#pragma GCC unroll 16
    for (int j = 0; j < m; ++j) bw[j] = jg[j] * inv;
    const V y = (F + Kc * (c + s)) * inv;
    S.y[i] = y;
    S.y0[i] = y;
    const V x0 = jg[0] * inv;
    nrm += x0 * x0;
#pragma GCC unroll 16
    for (int cc = 0; cc + 1 < m; ++cc) dot[cc] += x0 * (jg[1 + cc] * inv);
    dot[m - 1] += x0 * y;
  }

  // ---- QR of the stacked [I_m; B] by m Householder reflections, so that
  // M = I + J_G^T W J_G = R^T R is never formed: forming M squares the
  // condition number (W reaches 1/tol^2 on active rows); the QR keeps it.
  // Row j of the identity block is untouched until reflection j, so each
  // reflector has the form v = [1 + |x|; x_B] with x = [1; B(:, j)], and
  // v^T of a column right of j is the dot product of B(:, j) with it. The
  // same reflections applied to [0; y] give z with J_G^T W r = R^T z.
  // One pass over the rows per reflection: it applies reflection j and, from
  // the updated rows, accumulates the norm and dot products reflection j + 1
  // needs (the first ones come from the row pass above). The last reflection
  // only yields R's corner and z. Fully unrolled for compile-time m, so the
  // dot products live in registers.
#pragma GCC unroll 16
  for (int j = 0; j < m; ++j) {
    const V nr = vsqrt(nrm);
    const V v0 = 1.0 + nr;
    const V inv_nr = vrecip(nr);
    const V tau = inv_nr * vrecip(v0);  // 2 / (v^T v), v^T v = 2 |x| (|x| + 1)
    S.R[j * m + j] = -nr;
    S.Rd[j] = -inv_nr;  // the triangular solves multiply by it
    const int w = m - j - 1;  // columns right of j
    for (int cc = 0; cc <= w; ++cc) dot[cc] *= tau;
    for (int cc = 0; cc < w; ++cc) S.R[j * m + j + 1 + cc] = -dot[cc] * v0;
    S.z[j] = -dot[w] * v0;
    if (w == 0) break;
    V next[MA + 1];  // the dot products of reflection j + 1 (w - 1 columns, then y)
    for (int cc = 0; cc < w; ++cc) next[cc] = V{};
    nrm = splat(1.0);
    for (int i = 0; i < k; ++i) {
      V* row = S.Bw + size_t(i) * m + j;
      const V xb = row[0];
      V u[MA];
      for (int cc = 0; cc < w; ++cc) {
        u[cc] = row[1 + cc] - dot[cc] * xb;
        row[1 + cc] = u[cc];
      }
      const V y = S.y[i] - dot[w] * xb;
      S.y[i] = y;
      nrm += u[0] * u[0];
      for (int cc = 0; cc + 1 < w; ++cc) next[cc] += u[0] * u[1 + cc];
      next[w - 1] += u[0] * y;
    }
    for (int cc = 0; cc < w; ++cc) dot[cc] = next[cc];
  }

  // R^-1 x and R^-T x in place (R upper triangular, row-major).
  auto solve_R = [&](V* x) {
    for (int i = m - 1; i >= 0; --i) {
      V xi = x[i];
      for (int q = i + 1; q < m; ++q) xi -= S.R[i * m + q] * x[q];
      x[i] = xi * S.Rd[i];
    }
  };
  auto solve_RT = [&](V* x) {
    for (int i = 0; i < m; ++i) {
      V xi = x[i];
      for (int q = 0; q < i; ++q) xi -= S.R[q * m + i] * x[q];
      x[i] = xi * S.Rd[i];
    }
  };
  // b = -M^-1 J_G^T W r = -R^-1 z;  t = N_a alpha = R^-1 R^-T alpha.
  for (int j = 0; j < m; ++j) {
    S.b[j] = -S.z[j];
    S.t[j] = S.alpha[j];
  }
  solve_R(S.b);
  const bool smooth = mod.basis == BasisType::Smooth;
  if (!smooth) {
    solve_RT(S.t);
    solve_R(S.t);
  } else {
    // Smooth basis: its action block is T = N_a^{1/2} (docs/projector.md),
    // from a cyclic Jacobi eigen-decomposition of N_a = R^-1 R^-T run on all
    // lanes at once (same rotation order, per-lane angles; lanes with
    // nothing left to rotate get angle 0). Then t = T alpha.
    V* A = S.Am;
    V* Q = S.Vm;
    for (int col = 0; col < m; ++col) {
      for (int j = 0; j < m; ++j) S.t[j] = splat(j == col ? 1.0 : 0.0);
      solve_RT(S.t);
      solve_R(S.t);
      for (int j = 0; j < m; ++j) A[j * m + col] = S.t[j];
    }
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < i; ++j) A[i * m + j] = A[j * m + i] = 0.5 * (A[i * m + j] + A[j * m + i]);
    for (int i = 0; i < m * m; ++i) Q[i] = splat(i % (m + 1) == 0 ? 1.0 : 0.0);
    for (int sweep = 0; sweep < 50; ++sweep) {
      V off = V{}, diag = V{};
      for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) (i == j ? diag : off) += A[i * m + j] * A[i * m + j];
      // Converged (or non-finite: such lanes are stopped below anyway).
      const VI done = (off <= 1e-30 * (diag + off)) | ~vfinite(off);
      bool all_done = true;
      for (int l = 0; l < L; ++l) all_done = all_done && done[l];
      if (all_done) break;
      for (int pp = 0; pp < m - 1; ++pp) {
        for (int q = pp + 1; q < m; ++q) {
          const V apq = A[pp * m + q];
          const VI active = vmax(apq, -apq) > 1e-290;
          const V theta = (A[q * m + q] - A[pp * m + pp]) * vrecip(active ? 2.0 * apq : splat(1.0));
          // |theta| capped at 1e150: t below 5e-151 is no rotation either way,
          // and theta^2 stays finite.
          const V at = vmin(vmax(theta, -theta), splat(1e150));
          V t = vrecip(at + vsqrt(at * at + 1.0));
          t = theta < 0.0 ? -t : t;
          t = active ? t : V{};
          const V c = vrecip(vsqrt(t * t + 1.0)), sn = t * c;
          for (int r = 0; r < m; ++r) {  // A <- J^T A J: columns, then rows
            const V akp = A[r * m + pp], akq = A[r * m + q];
            A[r * m + pp] = c * akp - sn * akq;
            A[r * m + q] = sn * akp + c * akq;
          }
          for (int r = 0; r < m; ++r) {
            const V apk = A[pp * m + r], aqk = A[q * m + r];
            A[pp * m + r] = c * apk - sn * aqk;
            A[q * m + r] = sn * apk + c * aqk;
          }
          for (int r = 0; r < m; ++r) {
            const V vkp = Q[r * m + pp], vkq = Q[r * m + q];
            Q[r * m + pp] = c * vkp - sn * vkq;
            Q[r * m + q] = sn * vkp + c * vkq;
          }
        }
      }
    }
    // sqrt of the eigenvalues; below 1e-13 of the largest they count as 0
    // (as in the general path). N_a's eigenvalues are in (0, 1].
    V dmax = V{};
    for (int j = 0; j < m; ++j) dmax = vmax(dmax, A[j * m + j]);
    V w[MA];
    for (int j = 0; j < m; ++j) {
      const V d = A[j * m + j];
      const V sd = (d > 1e-13 * dmax) & (d > 0.0) ? vsqrt(vmax(d, V{})) : V{};
      V acc = V{};
      for (int r = 0; r < m; ++r) acc += Q[r * m + j] * S.alpha[r];
      w[j] = acc * sd;
      A[j * m + j] = sd;  // kept for the basis output
    }
    for (int j = 0; j < m; ++j) {
      V acc = V{};
      for (int r = 0; r < m; ++r) acc += Q[j * m + r] * w[r];
      S.t[j] = acc;
    }
  }

  // ---- lambda: largest scale of the tangential part keeping a in [-1, 1]^m.
  V lam = splat(1.0);
  VI bias_out = VI{};
  for (int j = 0; j < m; ++j) {
    const V b = S.b[j], t = S.t[j];
    bias_out |= (b > 1.0) | (b < -1.0);
    const V lim = t > 0.0 ? (1.0 - b) / t : (t < 0.0 ? (-1.0 - b) / t : splat(1.0));
    lam = vmin(lim, lam);
  }
  // !(lam > 0) also catches NaN.
  lam = (bias_out | ~(lam > 0.0)) ? V{} : lam;
  if (mod.bounds == BoundRule::CorrectionFirst) {
    // b outside the box: scaled into it as a whole, keeping its direction.
    V bmax = V{};
    for (int j = 0; j < m; ++j) bmax = vmax(bmax, vmax(S.b[j], -S.b[j]));
    const V scale = bias_out ? 1.0 / bmax : splat(1.0);
    for (int j = 0; j < m; ++j) S.b[j] *= scale;
  }
  for (int j = 0; j < m; ++j) S.a[j] = S.b[j] + lam * S.t[j];

  // ---- slack controls u_s = -A^-1 (r + J_G a), into y. J_G a = J_q (G a)
  // when J_q is at hand, so J_G never has to be stored.
  VI ok = ~VI{};
  if (store_slack) {
    V* ga = S.Ga;
    if (need_JqT) {
      for (int t = 0; t < n; ++t) {
        V acc = V{};
        if (diagG) {
          acc = S.GT[t] * S.a[t];
        } else {
#pragma GCC unroll 16
          for (int j = 0; j < m; ++j) acc += S.GT[size_t(t) * m + j] * S.a[j];
        }
        ga[t] = acc;
      }
    }
    for (int i = 0; i < k; ++i) {
      V acc = V{};
      if (need_JqT) {
        for (int t = 0; t < n; ++t) acc += S.JqT[i * n + t] * ga[t];
      } else {
        const V* jg = S.JG + size_t(i) * m;
#pragma GCC unroll 16
        for (int j = 0; j < m; ++j) acc += jg[j] * S.a[j];
      }
      const V us = -(S.y0[i] + acc * S.inv[i]);
      S.y[i] = us;
      ok &= vfinite(us);
    }
  }
  for (int j = 0; j < m; ++j) ok &= vfinite(S.a[j]);

  // ---- scatter back to env-major outputs. Lanes with a non-finite model
  // (NaN/Inf in f, G, c, J or xdot) stop: a = 0, u_s = 0, lambda = 0.
  for (int j = 0; j < m; ++j) S.a[j] = ok ? S.a[j] : V{};
  for (int i = 0; i < k; ++i) S.y[i] = ok ? S.y[i] : V{};
  lam = ok ? lam : V{};
  const int valid = hi - lo;
  if (valid == L) {
    double* dst[L];
    for (int l = 0; l < L; ++l) dst[l] = B.a.data() + size_t(lo + l) * m;
    scatter_lanes(S.a, m, dst);
    if (store_slack) {
      for (int l = 0; l < L; ++l) dst[l] = B.slack_u.data() + size_t(lo + l) * k;
      scatter_lanes(S.y, k, dst);
      for (int l = 0; l < L; ++l) dst[l] = B.s.data() + size_t(lo + l) * k;
      scatter_lanes(S.s, k, dst);
    }
  } else {
    for (int l = 0; l < valid; ++l) {
      const size_t e = size_t(lo + l);
      for (int j = 0; j < m; ++j) B.a[e * m + j] = S.a[j][l];
      if (!store_slack) continue;
      for (int i = 0; i < k; ++i) B.slack_u[e * k + i] = S.y[i][l];
      for (int i = 0; i < k; ++i) B.s[e * k + i] = S.s[i][l];
    }
  }
  for (int l = 0; l < valid; ++l) {
    B.lambda[lo + l] = lam[l];
    B.status[lo + l] = (alpha_bad[l] ? kStatusAlphaNonFinite : 0u) | (bias_out[l] ? kStatusBiasOutOfBounds : 0u) |
                       (ok[l] ? 0u : kStatusModelNonFinite);
  }

  if (store_basis && smooth) {
    // T = Q diag(sqrt d) Q^T (sqrt d on A's diagonal).
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) {
        V acc = V{};
        for (int r = 0; r < m; ++r) acc += S.Vm[i * m + r] * S.Am[r * m + r] * S.Vm[j * m + r];
        for (int l = 0; l < hi - lo; ++l) B.Na[size_t(lo + l) * m * m + i * m + j] = acc[l];
      }
  } else if (store_basis) {
    // N_a = M^-1 = R^-1 R^-T, one column per unit right-hand side.
    for (int col = 0; col < m; ++col) {
      for (int j = 0; j < m; ++j) S.t[j] = splat(j == col ? 1.0 : 0.0);
      solve_RT(S.t);
      solve_R(S.t);
      for (int l = 0; l < hi - lo; ++l) {
        double* Na = B.Na.data() + size_t(lo + l) * m * m;
        for (int j = 0; j < m; ++j) Na[j * m + col] = S.t[j][l];
      }
    }
  }
}

using LaneFn = void (*)(const ProjectorModel&, ProjectorBatch&, int, int, LaneScratch&, bool, bool);

// Compile-time m for the common action dimensions; dynamic beyond.
LaneFn lane_kernel_for(int m) {
  switch (m) {
    case 1: return project_lanes<1>;
    case 2: return project_lanes<2>;
    case 3: return project_lanes<3>;
    case 4: return project_lanes<4>;
    case 5: return project_lanes<5>;
    case 6: return project_lanes<6>;
    case 7: return project_lanes<7>;
    case 8: return project_lanes<8>;
    default: return nullptr;
  }
}

// Per-env scratch for the general path. Every matrix is sized once per
// model shape; afterwards all products write into these buffers (noalias,
// in-place solves), so the path does not allocate per call.
struct GeneralScratch {
  using Mat = Eigen::MatrixXd;
  using Vec = Eigen::VectorXd;
  using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  int n = -1, m = -1, k = -1, ke = -1, p = -1;
  Mat JG, stack, R, Rinv, Minv, JE, MJ, S, Spinv, Na, T, A, V, VD, MJS;
  Vec F, r, rate, z, g, alpha, b, t, a, rE, mu, d, Mg, JEMg;
  Eigen::HouseholderQR<Mat> qr;

  void setup(const ProjectorModel& mod) {
    const int e = mod.num_equality();
    if (mod.n == n && mod.m == m && mod.k == k && e == ke && mod.p == p) return;
    n = mod.n; m = mod.m; k = mod.k; ke = e; p = mod.p;
    const int ki = k - ke;
    JG.resize(k, m); stack.resize(m + ki, m + 1); R.resize(m, m); Rinv.resize(m, m); Minv.resize(m, m);
    JE.resize(ke, m); MJ.resize(m, ke); S.resize(ke, ke); Spinv.resize(ke, ke); Na.resize(m, m); T.resize(m, m);
    MJS.resize(m, ke);
    F.resize(k); r.resize(k); rate.resize(k); z.resize(m); g.resize(m); alpha.resize(m);
    b.resize(m); t.resize(m); a.resize(m); rE.resize(ke); mu.resize(ke); Mg.resize(m); JEMg.resize(ke);
    qr = Eigen::HouseholderQR<Mat>(m + ki, m + 1);
  }
};

// Cyclic Jacobi eigen-decomposition of the symmetric A (overwritten): V holds
// the eigenvectors (columns), d the eigenvalues. Small matrices only (m or the
// number of equality rows); no allocation; sweeps until the off-diagonal mass
// is below 1e-30 of the total (quadratic convergence: a handful of sweeps).
void jacobi_eigen(Eigen::MatrixXd& A, Eigen::MatrixXd& V, Eigen::VectorXd& d) {
  const Eigen::Index n = A.rows();
  V.setIdentity(n, n);
  for (int sweep = 0; sweep < 50; ++sweep) {
    double off = 0.0, total = 0.0;
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) (i == j ? total : off) += A(i, j) * A(i, j);
    if (off <= 1e-30 * (total + off) || off == 0.0) break;
    for (Eigen::Index p = 0; p < n - 1; ++p) {
      for (Eigen::Index q = p + 1; q < n; ++q) {
        const double apq = A(p, q);
        if (apq == 0.0) continue;
        const double theta = (A(q, q) - A(p, p)) / (2.0 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
        for (Eigen::Index k = 0; k < n; ++k) {  // A <- J^T A J, columns then rows
          const double akp = A(k, p), akq = A(k, q);
          A(k, p) = c * akp - s * akq;
          A(k, q) = s * akp + c * akq;
        }
        for (Eigen::Index k = 0; k < n; ++k) {
          const double apk = A(p, k), aqk = A(q, k);
          A(p, k) = c * apk - s * aqk;
          A(q, k) = s * apk + c * aqk;
        }
        for (Eigen::Index k = 0; k < n; ++k) {
          const double vkp = V(k, p), vkq = V(k, q);
          V(k, p) = c * vkp - s * vkq;
          V(k, q) = s * vkp + c * vkq;
        }
      }
    }
  }
  d = A.diagonal();
}

// out = V f(lambda) V^T for the symmetric PSD X (eigenvalues below rel * max
// count as zero); f = sqrt (smooth basis) or 1/x (pseudo-inverse).
// Returns true when some eigenvalue was dropped.
bool psd_function(GeneralScratch& W, const Eigen::MatrixXd& X, double rel, bool sqrt_fn, Eigen::MatrixXd& out) {
  W.A = X;
  jacobi_eigen(W.A, W.V, W.d);
  const double emax = W.d.size() ? std::max(W.d.maxCoeff(), 0.0) : 0.0;
  const double thr = emax * rel;
  bool loss = false;
  for (Eigen::Index i = 0; i < W.d.size(); ++i) {
    const bool pos = W.d(i) > thr && W.d(i) > 0.0;
    loss = loss || !pos;
    W.d(i) = pos ? (sqrt_fn ? std::sqrt(W.d(i)) : 1.0 / W.d(i)) : 0.0;
  }
  W.VD = W.V;
  for (Eigen::Index c = 0; c < W.VD.cols(); ++c) W.VD.col(c) *= W.d(c);
  out.noalias() = W.VD * W.V.transpose();
  return loss;
}

void project_general_one(const ProjectorModel& mod, ProjectorBatch& B, int e, GeneralScratch& W, bool store_basis,
                         bool store_slack) {
  using RowMap = Eigen::Map<const GeneralScratch::RowMat>;
  using VecMap = Eigen::Map<const Eigen::VectorXd>;
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p, ke = W.ke;
  uint32_t status = 0;
  const double* al = B.alpha.data() + size_t(e) * m;
  for (int j = 0; j < m; ++j) {
    double v = al[j];
    if (!finite(v)) { v = 0.0; status |= kStatusAlphaNonFinite; }
    W.alpha(j) = std::clamp(v, -1.0, 1.0);
  }
  const RowMap Jq(B.Jq.data() + size_t(e) * k * n, k, n);
  if (mod.g_form == GForm::Diagonal)
    W.JG.noalias() = Jq * VecMap(B.G.data() + size_t(e) * n, n).asDiagonal();
  else
    W.JG.noalias() = Jq * RowMap(B.G.data() + size_t(e) * n * m, n, m);
  W.F.setZero();
  if (mod.has_drift) W.F.noalias() += Jq * VecMap(B.f.data() + size_t(e) * n, n);
  if (p > 0) W.F.noalias() += RowMap(B.Jx.data() + size_t(e) * k * p, k, p) * VecMap(B.xdot.data() + size_t(e) * p, p);

  const double* c = B.c.data() + size_t(e) * k;
  double s_dummy = 0.0;  // slack outputs not stored: write into a sink
  double* s_out = store_slack ? B.s.data() + size_t(e) * k : nullptr;
  auto s_at = [&](int i) -> double& { return s_out ? s_out[i] : s_dummy; };
  // QR of [I, 0; A^-1 J_I, A^-1 r_I]: its R holds R with I + J_I^T W J_I =
  // R^T R in the first m columns and z with J_I^T W r_I = R^T z in the last,
  // without forming the products (as in the fast path).
  W.stack.setZero();
  W.stack.topLeftCorner(m, m).setIdentity();
  for (int i = 0, ie = 0, ii = 0; i < k; ++i) {
    if (mod.equality[i]) {
      s_at(i) = 0.0;
      W.r(i) = W.F(i) + mod.K_c * c[i];
      W.JE.row(ie) = W.JG.row(i);
      W.rE(ie++) = W.r(i);
      continue;
    }
    const double s = slack_value(c[i], mod.tol[i]);
    s_at(i) = s;
    W.rate(i) = slack_rate(mod.slack[i], s, mod.beta[i], mod.tol[i]);
    W.r(i) = W.F(i) + mod.K_c * (c[i] + s);
    W.stack.row(m + ii).head(m) = W.JG.row(i) / W.rate(i);
    W.stack(m + ii++, m) = W.r(i) / W.rate(i);
  }

  double* a_out = B.a.data() + size_t(e) * m;
  double* us_out = store_slack ? B.slack_u.data() + size_t(e) * k : nullptr;
  const bool model_ok = W.stack.allFinite() && W.r.allFinite() && W.JE.allFinite();
  if (model_ok) {
    W.qr.compute(W.stack);
    W.z = W.qr.matrixQR().col(m).head(m);
    W.R = W.qr.matrixQR().topLeftCorner(m, m).triangularView<Eigen::Upper>();
    W.Rinv.setIdentity();
    W.R.triangularView<Eigen::Upper>().solveInPlace(W.Rinv);
    W.Minv.noalias() = W.Rinv * W.Rinv.transpose();
    W.b.noalias() = -W.Rinv * W.z;
    if (ke > 0) {
      // Equality rows: the tangent space is restricted to null(J_E) in the
      // M-metric. S = J_E M^-1 J_E^T; dependent rows are solved in least squares.
      W.g.noalias() = W.R.transpose() * W.z;  // J_I^T W r_I
      W.MJ.noalias() = W.Minv * W.JE.transpose();
      W.S.noalias() = W.JE * W.MJ;
      if (psd_function(W, W.S, 1e-12, false, W.Spinv)) status |= kStatusEqualityRankLoss;
      W.MJS.noalias() = W.MJ * W.Spinv;
      W.Na = W.Minv;
      W.Na.noalias() -= W.MJS * W.MJ.transpose();
      W.Mg.noalias() = W.Minv * W.g;
      W.JEMg.noalias() = W.JE * W.Mg;
      W.JEMg -= W.rE;
      W.mu.noalias() = W.Spinv * W.JEMg;
      W.b.noalias() = W.MJ * W.mu;
      W.b -= W.Mg;
    } else {
      W.Na = W.Minv;
    }
    if (mod.basis == BasisType::Smooth) {
      // Action block of the Procrustes basis: N_a^{1/2} (see docs/projector.md).
      psd_function(W, W.Na, 1e-13, true, W.T);
    } else {
      W.T = W.Na;
    }
    W.t.noalias() = W.T * W.alpha;
    bool bias_out = false;
    const double lam = tangent_scale(W.b.data(), W.t.data(), m, &bias_out);
    if (bias_out) status |= kStatusBiasOutOfBounds;
    if (bias_out && mod.bounds == BoundRule::CorrectionFirst) W.b /= W.b.cwiseAbs().maxCoeff();
    W.a = W.b + lam * W.t;
    bool ok = W.a.allFinite();
    for (int i = 0; i < (us_out ? k : 0); ++i) {
      if (mod.equality[i]) { us_out[i] = 0.0; continue; }
      us_out[i] = -(W.r(i) + W.JG.row(i).dot(W.a)) / W.rate(i);
      ok = ok && finite(us_out[i]);
    }
    if (ok) {
      for (int j = 0; j < m; ++j) a_out[j] = W.a(j);
      B.lambda[e] = lam;
      if (store_basis)
        Eigen::Map<GeneralScratch::RowMat>(B.Na.data() + size_t(e) * m * m, m, m) = W.T;
      B.status[e] = status;
      return;
    }
  }
  for (int j = 0; j < m; ++j) a_out[j] = 0.0;
  for (int i = 0; i < (us_out ? k : 0); ++i) us_out[i] = 0.0;
  B.lambda[e] = 0.0;
  B.status[e] = status | kStatusModelNonFinite;
  if (store_basis) std::fill_n(B.Na.data() + size_t(e) * m * m, size_t(m) * m, 0.0);
}

void check_batch(const ProjectorModel& mod, const ProjectorBatch& B) {
  const size_t N = static_cast<size_t>(B.N);
  const size_t gsz = mod.g_form == GForm::Diagonal ? size_t(mod.n) : size_t(mod.n) * mod.m;
  const bool ok = B.G.size() == N * gsz && B.c.size() == N * mod.k && B.Jq.size() == N * mod.k * mod.n &&
                  B.Jx.size() == N * mod.k * mod.p && B.xdot.size() == N * mod.p && B.alpha.size() == N * mod.m &&
                  B.a.size() == N * mod.m && B.slack_u.size() == N * mod.k && B.s.size() == N * mod.k &&
                  B.lambda.size() == N && B.status.size() == N && (!mod.has_drift || B.f.size() == N * mod.n);
  if (!ok) throw std::invalid_argument("projector batch: array sizes do not match the model (use ProjectorBatch(model, N))");
}

// The calling thread's scratch, behind a call that is never inlined: the
// kernels then hold a plain reference, instead of the compiler re-deriving the
// thread-local address at every use (a __tls_get_addr call each time in the
// position-independent build that the Python module links).
template <class Scratch>
[[gnu::noinline]] Scratch& thread_scratch() {
  thread_local Scratch scratch;
  return scratch;
}

}  // namespace

void project_range(const ProjectorModel& mod, ProjectorBatch& B, int begin, int end, const ProjectOptions& opt) {
  if (begin >= end) return;
  if (opt.store_basis && B.Na.size() != size_t(B.N) * mod.m * mod.m) B.Na.assign(size_t(B.N) * mod.m * mod.m, 0.0);
  // Lane kernels: compile-time m up to 8, dynamic m up to 16 (accumulator
  // capacity); larger m takes the general path.
  const bool fast = mod.num_equality() == 0 && mod.m <= 16;
  if (fast) {
    LaneScratch& scratch = thread_scratch<LaneScratch>();
    scratch.setup(mod);
    LaneFn fn = lane_kernel_for(mod.m);
    if (!fn) fn = project_lanes<0>;
    for (int lo = begin; lo < end; lo += kLanes) fn(mod, B, lo, std::min(lo + kLanes, end), scratch, opt.store_basis, opt.store_slack);
  } else {
    GeneralScratch& scratch = thread_scratch<GeneralScratch>();
    scratch.setup(mod);
    for (int e = begin; e < end; ++e) project_general_one(mod, B, e, scratch, opt.store_basis, opt.store_slack);
  }
}

void project_batch(const ProjectorModel& mod, ProjectorBatch& B, const ProjectOptions& opt) {
  mod.validate();
  check_batch(mod, B);
  if (opt.store_basis && B.Na.size() != size_t(B.N) * mod.m * mod.m) B.Na.assign(size_t(B.N) * mod.m * mod.m, 0.0);
  if (!opt.parallel) {
    project_range(mod, B, 0, B.N, opt);
    return;
  }
  parallel_blocks(B.N, kBlockEnvs, [&](int64_t lo, int64_t hi) {
    project_range(mod, B, static_cast<int>(lo), static_cast<int>(hi), opt);
  });
}

}  // namespace atacom
