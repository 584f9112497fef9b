// SafeLayer's QP for m <= 2 controls (nav: v and omega), exact and without
// iterations: the solution is the projection of a_pi onto the affine set of
// a linearly independent subset of the active constraints with non-negative
// multipliers (Caratheodory), so with m <= 2 it is a_pi itself, a_pi
// projected onto one constraint's line, or the vertex of two. Every such
// candidate that is feasible is at least as far from a_pi as the solution,
// and the solution is one of them: the closest feasible candidate is the
// answer. Pruned without changing it:
//   - a single line only with a positive multiplier, i.e. a row violated at
//     a_pi (a_pi is inside the box, so never a bound alone);
//   - a vertex only when one of its two constraints is violated at a_pi
//     (sum of lambda_t g_t.(a_pi - x) = |a_pi - x|^2 > 0) and both
//     multipliers are >= 0;
//   - a candidate no closer than the best so far, or closer to a_pi than the
//     farthest violated row's distance by more than the tolerance allows.
// Geometry on unit-normal rows; feasibility on the raw rows (kSafeLayerFeasTol)
// and the box (slack kBoxSlack, then clipped), as the NNLS path checks.
// Also the infeasible case's tie-break for m <= 2 (the least-violation action
// closest to a_pi, in closed form from Newton's least-violation action).
#include <algorithm>
#include <cmath>

#include "atacom/safelayer.hpp"
#include "kernels/safelayer_qp.hpp"

namespace atacom::safelayer_qp {

namespace {

constexpr double kParallel = 1e-12;  // |sin| of the angle below which two lines count as parallel
// A vertex of lines closer than this to parallel is ill-conditioned (its
// rounding error ~ 1e-16 / |sin| nears the tolerance): when no candidate is
// feasible and such a pair was seen, the enumeration does not decide.
constexpr double kIllConditioned = 1e-6;
// Below this |sin| two unit normals are parallel up to the rounding of their
// normalisation and of D itself (FMA-contracted, D of exactly opposite rows
// is a product's rounding error, ~1e-17): their vertex is rounding noise,
// not an ill-conditioned candidate (nav's opposite wall rows).
constexpr double kRoundingParallel = 1e-15;

// Constraint t of the planar problem: t < kk a kept row (unit normal), then
// a_j <= 1 and -a_j <= 1 for each j.
struct Con {
  double n0, n1, r;  // unit normal (n1 = 0 for m = 1), residual n.a_pi - h at a_pi
};

template <int m>
int planar_m(int kk, const int* kept, const double* g, const double* hk, const double* gscale, const double* a_pi,
              double* a, double* mu, Scratch& S) {
  const int M = kk + 2 * m;
  Con* con = reinterpret_cast<Con*>(S.planar.data());
  double far = 0.0;  // largest distance of a violated row from a_pi
  int far_row = -1;
  for (int c = 0; c < kk; ++c) {
    const double* gi = g + size_t(kept[c]) * m;
    const double inv = 1.0 / gscale[c];
    Con& q = con[c];
    q.n0 = gi[0] * inv;
    q.n1 = m == 2 ? gi[1] * inv : 0.0;
    double r = -hk[c];
    for (int j = 0; j < m; ++j) r += gi[j] * a_pi[j];
    q.r = r * inv;
    if (r > kSafeLayerFeasTol && q.r > far) far = q.r, far_row = c;
  }
  for (int j = 0; j < m; ++j) {
    con[kk + j] = {j == 0 ? 1.0 : 0.0, j == 1 ? 1.0 : 0.0, a_pi[j] - 1.0};
    con[kk + m + j] = {j == 0 ? -1.0 : 0.0, j == 1 ? -1.0 : 0.0, -a_pi[j] - 1.0};
  }
  if (far_row < 0) {  // no row violated (the relaxed rows of the infeasible case can be): a_pi
    std::copy_n(a_pi, m, a);
    if (mu) std::fill_n(mu, M, 0.0);
    return 1;
  }
  // A candidate at distance d from a_pi violates the farthest row by at least
  // |g| (far - d): skip it when that exceeds the tolerance.
  const double d_min = std::max(0.0, far - 2.0 * kSafeLayerFeasTol / gscale[far_row]);
  const double d_min2 = d_min * d_min;
  double best = INFINITY;
  int best_s = -1, best_t = -1;
  double best_l[2] = {0.0, 0.0};
  double x[2], xb[2] = {0.0, 0.0};
  bool ill = false;
  auto feasible = [&](const double* d) {
    for (int j = 0; j < m; ++j) {
      x[j] = a_pi[j] - d[j];
      if (!(std::fabs(x[j]) <= 1.0 + kBoxSlack)) return false;
      x[j] = std::clamp(x[j], -1.0, 1.0);
    }
    for (int c = 0; c < kk; ++c) {
      const double* gi = g + size_t(kept[c]) * m;
      double r = -hk[c];
      for (int j = 0; j < m; ++j) r += gi[j] * x[j];
      if (!(r <= kSafeLayerFeasTol)) return false;
    }
    return true;
  };
  // Lines of the violated rows: d = r n, lambda = r.
  for (int s = 0; s < kk; ++s) {
    const Con& q = con[s];
    if (!(q.r > 0.0)) continue;
    const double d2 = q.r * q.r;
    if (d2 >= best || d2 < d_min2) continue;
    const double d[2] = {q.r * q.n0, q.r * q.n1};
    if (feasible(d)) best = d2, best_s = s, best_t = -1, best_l[0] = q.r, xb[0] = x[0], xb[1] = x[1];
  }
  // Vertices (m = 2): s a violated row, t any other constraint (a violated
  // row t < s was paired with s already).
  if constexpr (m == 2)
    for (int s = 0; s < kk; ++s) {
      const Con& p = con[s];
      if (!(p.r > 0.0)) continue;
      for (int t = 0; t < M; ++t) {
        if (t == s || (t < s && con[t].r > 0.0)) continue;
        const Con& q = con[t];
        const double D = p.n0 * q.n1 - p.n1 * q.n0;
        ill = ill || (std::fabs(D) > kRoundingParallel && !(std::fabs(D) > kIllConditioned));
        if (!(std::fabs(D) > kParallel)) continue;
        // [p; q] d = [p.r; q.r], then d = lp p + lq q.
        const double d[2] = {(p.r * q.n1 - q.r * p.n1) / D, (p.n0 * q.r - q.n0 * p.r) / D};
        const double d2 = d[0] * d[0] + d[1] * d[1];
        if (d2 >= best || d2 < d_min2) continue;
        const double lp = (d[0] * q.n1 - d[1] * q.n0) / D, lq = (p.n0 * d[1] - p.n1 * d[0]) / D;
        if (lp < 0.0 || lq < 0.0) continue;
        if (feasible(d)) best = d2, best_s = s, best_t = t, best_l[0] = lp, best_l[1] = lq, xb[0] = x[0], xb[1] = x[1];
      }
    }
  if (best_s < 0) return ill ? -1 : 0;
  std::copy_n(xb, m, a);
  if (mu) {
    std::fill_n(mu, M, 0.0);
    mu[best_s] = best_l[0];
    if (best_t >= 0) mu[best_t] = best_l[1];
  }
  return 1;
}

}  // namespace

bool planar_least_violation_tiebreak(int m, int kk, const int* kept, const double* g, const double* h,
                                     const double* gscale, const double* a_pi, double* a) {
  // The violations are constant over the convex set of minimisers (a sum of
  // convex terms is constant on a segment only if each is affine there, and
  // a squared violation is strictly convex where positive): a violated row
  // keeps g_i a, a satisfied row stays satisfied. So two violated rows with
  // independent normals pin a (for m = 1 one does); violated rows all
  // parallel to n leave the segment a + t u, u perpendicular to n, inside
  // the box and the satisfied rows, and the closest point to a_pi on it is
  // the answer.
  // a must be a least-violation action: Newton can stop short (line search,
  // iteration bound), and then the general relaxed QP decides, as before.
  // Stationarity over the box: the gradient sum max(0, r_i) g_i vanishes on
  // the free coordinates and points inward at the bounds (relative 1e-10).
  double res[kPlanarMaxRows];  // residuals at a
  double grad[2] = {0.0, 0.0}, size[2] = {0.0, 0.0};
  for (int c = 0; c < kk; ++c) {
    const double* gi = g + size_t(kept[c]) * m;
    double r = -h[kept[c]];
    for (int j = 0; j < m; ++j) r += gi[j] * a[j];
    res[c] = r;
    if (!(r > 0.0)) continue;
    for (int j = 0; j < m; ++j) grad[j] += r * gi[j], size[j] += std::fabs(r * gi[j]);
  }
  for (int j = 0; j < m; ++j) {
    const double tol = 1e-10 * size[j] + 1e-300;
    if (a[j] <= -1.0 ? grad[j] < -tol : a[j] >= 1.0 ? grad[j] > tol : std::fabs(grad[j]) > tol) return false;
  }
  int first = -1;
  for (int c = 0; c < kk; ++c) {
    if (!(res[c] > kSafeLayerFeasTol)) continue;
    if (m == 1) return true;
    if (first < 0) {
      first = c;
      continue;
    }
    // |sin| of the angle between the two normals, without dividing
    const double* p = g + size_t(kept[first]) * m;
    const double* q = g + size_t(kept[c]) * m;
    const double D = std::fabs(p[0] * q[1] - p[1] * q[0]), scale = gscale[first] * gscale[c];
    if (D > kIllConditioned * scale) return true;
    if (D > kRoundingParallel * scale) return false;  // nearly parallel: the general relaxed QP decides
  }
  const bool have = first >= 0;
  double n0 = 0.0, n1 = 0.0;
  if (have) {
    const double inv = 1.0 / gscale[first];
    n0 = g[size_t(kept[first]) * m] * inv;
    n1 = m == 2 ? g[size_t(kept[first]) * m + 1] * inv : 0.0;
  }
  if (!have || m == 1) return false;
  const double u0 = -n1, u1 = n0;
  double tlo = -INFINITY, thi = INFINITY;
  auto bound = [&](double gu, double s) {  // t gu <= s, s >= 0
    if (gu > 0.0) thi = std::min(thi, s / gu);
    else if (gu < 0.0) tlo = std::max(tlo, s / gu);
  };
  bound(u0, 1.0 - a[0]), bound(-u0, 1.0 + a[0]), bound(u1, 1.0 - a[1]), bound(-u1, 1.0 + a[1]);
  for (int c = 0; c < kk; ++c) {
    if (res[c] > kSafeLayerFeasTol) continue;  // violated, parallel to n
    const double* gi = g + size_t(kept[c]) * m;
    bound(gi[0] * u0 + gi[1] * u1, std::max(0.0, -res[c]));
  }
  const double t = std::clamp(u0 * (a_pi[0] - a[0]) + u1 * (a_pi[1] - a[1]), std::min(tlo, 0.0), std::max(thi, 0.0));
  a[0] = std::clamp(a[0] + t * u0, -1.0, 1.0);
  a[1] = std::clamp(a[1] + t * u1, -1.0, 1.0);
  return true;
}

int planar_solve(int m, int kk, const int* kept, const double* g, const double* hk, const double* gscale,
                  const double* a_pi, double* a, double* mu, Scratch& S) {
  return m == 2 ? planar_m<2>(kk, kept, g, hk, gscale, a_pi, a, mu, S)
                : planar_m<1>(kk, kept, g, hk, gscale, a_pi, a, mu, S);
}

}  // namespace atacom::safelayer_qp
