// SafeLayer's per-env QP:  min 1/2 |a - a_pi|^2  s.t.  g a <= h,  -1 <= a <= 1.
//
// With x = a - a_pi this is a least-distance problem (LDP) min |x| s.t.
// E x >= f, E = -A, f = A a_pi - b for A a <= b the rows and the box. Lawson
// and Hanson (Solving Least Squares Problems, ch. 23) solve it through one
// non-negative least-squares problem min_{u >= 0} |[E^T; f^T] u - e_{m+1}|:
// a zero residual means the rows are infeasible, otherwise
// x = E^T u / (1 - f^T u) and u / (1 - f^T u) are the KKT multipliers. NNLS
// is an active-set method with finite termination; its passive set has at
// most m + 1 columns, so every least-squares solve is a tiny Householder QR.
// The rows are normalised to unit |g_i| first, so the box rows and the
// constraint rows weigh alike in the NNLS tolerances.
//
// Infeasible: a projected Newton method minimises 1/2 sum max(0, g a - h)^2
// over the box (piecewise quadratic, so Newton ends once the violated set is
// right), then the LDP with every row relaxed to the violation found picks,
// among the least-violation actions, the one closest to a_pi.
#include "kernels/safelayer_qp.hpp"

#include <algorithm>
#include <cmath>

#include "atacom/safelayer.hpp"

namespace atacom::safelayer_qp {

namespace {

constexpr double kDualTol = 1e-12;   // NNLS: a column enters when its dual exceeds this (relative to its norm)
constexpr double kRankTol = 1e-11;   // Householder: a column this close to the span of the others is dependent
constexpr int kNewtonMax = 60;

template <class T>
void grow(std::vector<T>& v, size_t n) {
  if (v.size() < n) v.resize(n);
}

// min |E_P z - d| over the columns P of E (column-major, nr rows) by
// Householder QR. Returns false when the columns are (numerically) dependent.
bool least_squares(const double* E, int nr, const int* P, int np, const double* d, double* z, Scratch& S) {
  if (np > nr) return false;
  double* q = S.qr.data();             // nr x np, column-major
  double* diag = q + size_t(nr) * nr;  // R's diagonal
  double* rhs = S.rhs.data();
  for (int c = 0; c < np; ++c) std::copy_n(E + size_t(P[c]) * nr, nr, q + size_t(c) * nr);
  std::copy_n(d, nr, rhs);
  for (int c = 0; c < np; ++c) {
    double* col = q + size_t(c) * nr;
    double norm2 = 0.0, orig2 = 0.0;
    for (int i = c; i < nr; ++i) norm2 += col[i] * col[i];
    for (int i = 0; i < nr; ++i) orig2 += col[i] * col[i];
    const double norm = std::sqrt(norm2);
    if (!(norm > kRankTol * std::sqrt(orig2))) return false;
    const double alpha = col[c] > 0 ? -norm : norm;
    col[c] -= alpha;  // Householder vector v = col[c..]
    double vv = 0.0;
    for (int i = c; i < nr; ++i) vv += col[i] * col[i];
    auto reflect = [&](double* y) {
      double s = 0.0;
      for (int i = c; i < nr; ++i) s += col[i] * y[i];
      s = 2.0 * s / vv;
      for (int i = c; i < nr; ++i) y[i] -= s * col[i];
    };
    for (int c2 = c + 1; c2 < np; ++c2) reflect(q + size_t(c2) * nr);
    reflect(rhs);
    diag[c] = alpha;
  }
  for (int c = np - 1; c >= 0; --c) {
    double s = rhs[c];
    for (int c2 = c + 1; c2 < np; ++c2) s -= q[size_t(c2) * nr + c] * z[c2];
    z[c] = s / diag[c];
  }
  return true;
}

// Lawson-Hanson NNLS: min_{u >= 0} |E u - d|, E (nr x nc) column-major.
// Counts least-squares solves in *iters; returns false at the iteration bound.
bool nnls(const double* E, int nr, int nc, const double* d, double* u, Scratch& S, int max_iter, int* iters) {
  int* P = S.P.data();
  uint8_t* inP = S.inP.data();
  uint8_t* blocked = S.blocked.data();
  double* z = S.z.data();
  double* r = S.resid.data();
  for (int j = 0; j < nc; ++j) {
    u[j] = 0.0;
    inP[j] = blocked[j] = 0;
    double s = 0.0;
    for (int i = 0; i < nr; ++i) s += E[size_t(j) * nr + i] * E[size_t(j) * nr + i];
    S.colnorm[j] = std::sqrt(s);
  }
  std::copy_n(d, nr, r);
  int np = 0;
  for (;;) {
    int best = -1;
    double bw = 0.0;
    for (int j = 0; j < nc; ++j) {
      if (inP[j] || blocked[j]) continue;
      double w = 0.0;
      for (int i = 0; i < nr; ++i) w += E[size_t(j) * nr + i] * r[i];
      if (w > kDualTol * S.colnorm[j] && w > bw) bw = w, best = j;
    }
    if (best < 0 || np == nr) return true;
    P[np++] = best;
    inP[best] = 1;
    for (;;) {
      if (++*iters > max_iter) return false;
      if (!least_squares(E, nr, P, np, d, z, S)) {
        // The entering column is dependent on the passive ones: skip it.
        if (inP[best]) {
          int w = 0;
          for (int c = 0; c < np; ++c)
            if (P[c] != best) P[w++] = P[c];
          np = w;
          inP[best] = 0;
        }
        blocked[best] = 1;
        break;
      }
      bool positive = true;
      for (int c = 0; c < np; ++c) positive = positive && z[c] > 0.0;
      if (positive) {
        for (int c = 0; c < np; ++c) u[P[c]] = z[c];
        std::fill_n(blocked, nc, uint8_t{0});
        break;
      }
      double step = 1.0;
      for (int c = 0; c < np; ++c)
        if (z[c] <= 0.0) step = std::min(step, u[P[c]] / (u[P[c]] - z[c]));
      int w = 0;
      for (int c = 0; c < np; ++c) {
        const int j = P[c];
        u[j] += step * (z[c] - u[j]);
        if (u[j] <= 0.0 || (z[c] <= 0.0 && u[j] <= 1e-300 + 1e-15 * std::fabs(z[c]))) {
          u[j] = 0.0;
          inP[j] = 0;
        } else {
          P[w++] = j;
        }
      }
      np = w;
      if (np == 0) break;
    }
    std::copy_n(d, nr, r);
    for (int c = 0; c < np; ++c) {
      const double* col = E + size_t(P[c]) * nr;
      for (int i = 0; i < nr; ++i) r[i] -= col[i] * u[P[c]];
    }
  }
}

// LDP on the kept rows (unit normals gn, right-hand sides hn) and the box.
// Writes a and, when mu != nullptr, the multipliers of [rows, a <= 1, -a <= 1].
// Returns false when NNLS reports the rows infeasible.
bool ldp(int m, int kk, const double* gn, const double* hn, const double* a_pi, double* a, double* mu, Scratch& S,
         int* iters, bool* limit) {
  const int nr = m + 1, nc = kk + 2 * m;
  double* E = S.E.data();
  for (int c = 0; c < kk; ++c) {
    double* col = E + size_t(c) * nr;
    double f = -hn[c];
    for (int j = 0; j < m; ++j) {
      col[j] = -gn[size_t(c) * m + j];
      f += gn[size_t(c) * m + j] * a_pi[j];
    }
    col[m] = f;
  }
  for (int j = 0; j < m; ++j) {
    double* up = E + size_t(kk + j) * nr;      // a_j <= 1
    double* lo = E + size_t(kk + m + j) * nr;  // -a_j <= 1
    std::fill_n(up, nr, 0.0);
    std::fill_n(lo, nr, 0.0);
    up[j] = -1.0;
    up[m] = a_pi[j] - 1.0;
    lo[j] = 1.0;
    lo[m] = -a_pi[j] - 1.0;
  }
  double* d = S.d.data();
  std::fill_n(d, nr, 0.0);
  d[m] = 1.0;
  double* u = S.u.data();
  if (!nnls(E, nr, nc, d, u, S, 3 * nc, iters)) *limit = true;
  double rr = 1.0;
  for (int c = 0; c < nc; ++c) rr -= E[size_t(c) * nr + m] * u[c];
  if (!(rr > 1e-12)) return false;
  for (int j = 0; j < m; ++j) {
    double x = 0.0;
    for (int c = 0; c < nc; ++c) x += E[size_t(c) * nr + j] * u[c];
    a[j] = a_pi[j] + x / rr;
  }
  if (mu)
    for (int c = 0; c < nc; ++c) mu[c] = u[c] / rr;
  return true;
}

[[gnu::always_inline]] inline double max_row_violation(int m, int kk, const int* kept, const double* g, const double* h, const double* a) {
  double mx = -INFINITY;
  for (int c = 0; c < kk; ++c) {
    const int i = kept[c];
    double r = -h[i];
    for (int j = 0; j < m; ++j) r += g[size_t(i) * m + j] * a[j];
    mx = std::max(mx, r);
  }
  return mx;
}

// Inside the box up to kBoxSlack: clip and return true.
[[gnu::always_inline]] inline bool into_box(int m, double* a) {
  for (int j = 0; j < m; ++j)
    if (!(std::fabs(a[j]) <= 1.0 + kBoxSlack)) return false;
  for (int j = 0; j < m; ++j) a[j] = std::clamp(a[j], -1.0, 1.0);
  return true;
}

[[gnu::always_inline]] inline double violation_objective(int m, int kk, const int* kept, const double* g, const double* h, const double* a) {
  double s = 0.0;
  for (int c = 0; c < kk; ++c) {
    const int i = kept[c];
    double r = -h[i];
    for (int j = 0; j < m; ++j) r += g[size_t(i) * m + j] * a[j];
    if (r > 0) s += 0.5 * r * r;
  }
  return s;
}

// Projected Newton on 1/2 sum max(0, g a - h)^2 over the box, from a (inside).
[[gnu::always_inline]] inline void least_violation_newton(int m, int kk, const int* kept, const double* g, const double* h, double* a, Scratch& S,
                            int* iters) {
  double* grad = S.grad.data();
  double* H = S.H.data();
  double* dir = S.dir.data();
  double* trial = S.trial.data();
  int* freev = S.P.data();  // reused: indices of the free variables
  for (int it = 0; it < kNewtonMax; ++it) {
    ++*iters;
    std::fill_n(grad, m, 0.0);
    std::fill_n(H, size_t(m) * m, 0.0);
    double obj = 0.0;
    for (int c = 0; c < kk; ++c) {
      const double* gi = g + size_t(kept[c]) * m;
      double r = -h[kept[c]];
      for (int j = 0; j < m; ++j) r += gi[j] * a[j];
      if (r <= 0) continue;
      obj += 0.5 * r * r;
      for (int j = 0; j < m; ++j) {
        grad[j] += r * gi[j];
        for (int l = 0; l <= j; ++l) H[j * m + l] += gi[j] * gi[l];
      }
    }
    int nf = 0;
    for (int j = 0; j < m; ++j)
      if (!((a[j] <= -1.0 && grad[j] > 0) || (a[j] >= 1.0 && grad[j] < 0))) freev[nf++] = j;
    double pg = 0.0, tr = 0.0;
    for (int f = 0; f < nf; ++f) pg = std::max(pg, std::fabs(grad[freev[f]])), tr += H[freev[f] * m + freev[f]];
    if (obj == 0.0 || pg == 0.0 || tr == 0.0) return;
    // Newton step on the free block H_ff y = -grad_f (+ a relative ridge: it
    // is singular when fewer rows are violated than variables are free).
    // One or two free variables (m <= 2) in closed form, without the
    // Cholesky's dependent square roots and divisions; the guard is the
    // Cholesky's (second pivot det / H_00 at least the ridge).
    const double ridge = 1e-12 * tr / nf;
    double* y = S.x.data();
    if (nf == 1) {
      const double h00 = H[freev[0] * m + freev[0]] + ridge;
      y[0] = -grad[freev[0]] / std::max(h00, ridge);
    } else if (m == 2 && nf == 2) {
      const double h00 = H[0] + ridge, h10 = H[m], h11 = H[m + 1] + ridge;
      const double det = std::max(h00 * h11 - h10 * h10, ridge * h00);
      y[0] = (h10 * grad[1] - h11 * grad[0]) / det;
      y[1] = (h10 * grad[0] - h00 * grad[1]) / det;
    } else {
      double* L = S.qr.data();
      for (int p = 0; p < nf; ++p)
        for (int q = 0; q <= p; ++q) {
          double s = H[freev[p] * m + freev[q]] + (p == q ? ridge : 0.0);
          for (int t = 0; t < q; ++t) s -= L[p * m + t] * L[q * m + t];
          L[p * m + q] = p == q ? std::sqrt(std::max(s, ridge)) : s / L[q * m + q];
        }
      for (int p = 0; p < nf; ++p) {
        double s = -grad[freev[p]];
        for (int t = 0; t < p; ++t) s -= L[p * m + t] * y[t];
        y[p] = s / L[p * m + p];
      }
      for (int p = nf - 1; p >= 0; --p) {
        double s = y[p];
        for (int t = p + 1; t < nf; ++t) s -= L[t * m + p] * y[t];
        y[p] = s / L[p * m + p];
      }
    }
    std::fill_n(dir, m, 0.0);
    for (int p = 0; p < nf; ++p) dir[freev[p]] = y[p];
    bool accepted = false;
    double moved = 0.0;
    for (double t = 1.0; t > 1e-12; t *= 0.5) {
      double dec = 0.0;
      for (int j = 0; j < m; ++j) {
        trial[j] = std::clamp(a[j] + t * dir[j], -1.0, 1.0);
        dec += grad[j] * (trial[j] - a[j]);
      }
      if (violation_objective(m, kk, kept, g, h, trial) <= obj + 1e-4 * dec) {
        accepted = true;
        for (int j = 0; j < m; ++j) moved = std::max(moved, std::fabs(trial[j] - a[j]));
        break;
      }
    }
    if (!accepted) return;
    std::copy_n(trial, m, a);
    if (moved <= 1e-15) return;
  }
}

}  // namespace

void Scratch::setup(int m, int k) {
  const int nr = m + 1, nc = k + 2 * m;
  grow(E, size_t(nr) * nc);
  grow(d, nr);
  grow(u, nc);
  grow(z, nr + 1);
  grow(w, nc);
  grow(resid, nr);
  grow(colnorm, nc);
  grow(qr, size_t(std::max(nr, m)) * std::max(nr, m) + nr);
  grow(rhs, nr);
  grow(P, std::max(nr, m) + 1);
  grow(inP, nc);
  grow(blocked, nc);
  grow(gn, size_t(k) * m);
  grow(hn, k);
  grow(gscale, k);
  grow(h2, k);
  grow(x, m);
  grow(grad, m);
  grow(H, size_t(m) * m);
  grow(dir, m);
  grow(trial, m);
  grow(kept, k);
  grow(mu, nc);
  grow(a2, m);
  grow(planar, 3 * size_t(nc));
  grow(hk, k);
}

namespace {

// The solver with m a compile-time constant when M > 0 (loops over m unroll
// in the small helpers inlined here); M = 0 for any m.
template <int M>
Result solve_m(int m_any, int k, const double* g, const double* h, const double* a_pi, double* a, double* mult,
               Scratch& S, const Options& opt) {
  const int m = M > 0 ? M : m_any;
  Result R;
  if (mult) std::fill_n(mult, k + 2 * m, 0.0);
  // 1. a_pi itself; the row farthest outside (distance to its half-space).
  int kk = 0, worst = -1;
  double worst_dist = 0.0;
  bool stuck = false;  // a violated row the action cannot move this step
  // A kept row violated by more than twice the tolerance at every box point
  // (its least value over the box is -sum |g_ij| - h_i): no candidate of
  // steps 2-3 could pass their checks, so they are skipped (nav: 96% of its
  // infeasible envs, a row out of one period's reach).
  bool unreachable = false;
  for (int i = 0; i < k; ++i) {
    const double* gi = g + size_t(i) * m;
    double gg = 0.0, r = -h[i], low = -h[i];
    for (int j = 0; j < m; ++j) gg += gi[j] * gi[j], r += gi[j] * a_pi[j], low -= std::fabs(gi[j]);
    if (!(gg > kSafeLayerRowEps * kSafeLayerRowEps)) {
      stuck = stuck || h[i] < -kSafeLayerFeasTol;
      continue;
    }
    S.kept[kk] = i;
    S.gscale[kk] = std::sqrt(gg);
    ++kk;
    unreachable = unreachable || low > 2.0 * kSafeLayerFeasTol;
    if (r > kSafeLayerFeasTol && r / std::sqrt(gg) > worst_dist) worst_dist = r / std::sqrt(gg), worst = i;
  }
  const uint32_t stuck_bit = stuck ? kSafeLayerInfeasible : 0u;
  if (worst < 0) {
    std::copy_n(a_pi, m, a);
    R.status = stuck_bit;
    return R;
  }
  bool planar = opt.planar && m <= 2 && kk <= kPlanarMaxRows;
  int iters = 0;
  bool limit = false;
  // 2. Dalal's closed form on that row: exact when it lands in the feasible set.
  if (!unreachable) {
    const double* gw = g + size_t(worst) * m;
    double gg = 0.0, r = -h[worst];
    for (int j = 0; j < m; ++j) gg += gw[j] * gw[j], r += gw[j] * a_pi[j];
    const double lam = r / gg;
    for (int j = 0; j < m; ++j) a[j] = a_pi[j] - lam * gw[j];
    R.iterations = 1;
    bool in_box = true;
    for (int j = 0; j < m; ++j) in_box = in_box && std::fabs(a[j]) <= 1.0;
    if (in_box && max_row_violation(m, kk, S.kept.data(), g, h, a) <= kSafeLayerFeasTol) {
      if (mult) mult[worst] = lam;
      R.status = stuck_bit;
      return R;
    }
  }
  // 3. The exact QP: enumeration for m <= 2, else (or when the enumeration
  // cannot decide) NNLS on the LDP.
  bool ok = false;
  if (planar && !unreachable) {
    for (int c = 0; c < kk; ++c) S.hk[c] = h[S.kept[c]];
    iters = 1;
    const int res = planar_solve(m, kk, S.kept.data(), g, S.hk.data(), S.gscale.data(), a_pi, a, S.mu.data(), S);
    ok = res == 1;
    planar = res != -1;
  }
  if (!planar && !unreachable) {
    for (int c = 0; c < kk; ++c) {
      const int i = S.kept[c];
      for (int j = 0; j < m; ++j) S.gn[size_t(c) * m + j] = g[size_t(i) * m + j] / S.gscale[c];
      S.hn[c] = h[i] / S.gscale[c];
    }
    ok = ldp(m, kk, S.gn.data(), S.hn.data(), a_pi, a, S.mu.data(), S, &iters, &limit) && into_box(m, a) &&
         max_row_violation(m, kk, S.kept.data(), g, h, a) <= kSafeLayerFeasTol;
  }
  if (ok) {
    R.iterations = 1 + iters;
    R.status = stuck_bit | (limit ? kSafeLayerIterationLimit : 0u);
    if (mult) {
      for (int c = 0; c < kk; ++c) mult[S.kept[c]] = S.mu[c] / S.gscale[c];
      for (int j = 0; j < 2 * m; ++j) mult[k + j] = S.mu[kk + j];
    }
    return R;
  }
  // 4. Infeasible: least squared violation in the box, then the closest such action.
  std::copy_n(a_pi, m, a);
  least_violation_newton(m, kk, S.kept.data(), g, h, a, S, &iters);
  if (planar && planar_least_violation_tiebreak(m, kk, S.kept.data(), g, h, S.gscale.data(), a_pi, a)) {
    R.iterations = 1 + iters;
    R.status = stuck_bit | kSafeLayerInfeasible | (limit ? kSafeLayerIterationLimit : 0u);
    return R;
  }
  for (int c = 0; c < kk; ++c) {
    const int i = S.kept[c];
    double r = 0.0;
    for (int j = 0; j < m; ++j) r += g[size_t(i) * m + j] * a[j];
    S.hk[c] = std::max(h[i], r);
    S.h2[c] = S.hk[c] / S.gscale[c];
  }
  bool limit2 = false;
  double* a2 = S.a2.data();
  int relaxed = -1;  // 1 solved, 0 not, -1 ask NNLS
  if (planar) {
    ++iters;
    relaxed = planar_solve(m, kk, S.kept.data(), g, S.hk.data(), S.gscale.data(), a_pi, a2, nullptr, S);
  }
  if (relaxed == -1) {
    // unit normals (step 3's NNLS formed them unless it was skipped or the enumeration decided)
    for (int c = 0; c < kk; ++c)
      for (int j = 0; j < m; ++j) S.gn[size_t(c) * m + j] = g[size_t(S.kept[c]) * m + j] / S.gscale[c];
    relaxed = ldp(m, kk, S.gn.data(), S.h2.data(), a_pi, a2, nullptr, S, &iters, &limit2) && into_box(m, a2);
  }
  const bool relaxed_ok = relaxed == 1;
  if (relaxed_ok && violation_objective(m, kk, S.kept.data(), g, h, a2) <=
                        violation_objective(m, kk, S.kept.data(), g, h, a) * (1.0 + 1e-9) + 1e-300)
    std::copy_n(a2, m, a);
  R.iterations = 1 + iters;
  const bool violated = max_row_violation(m, kk, S.kept.data(), g, h, a) > kSafeLayerFeasTol;
  R.status = stuck_bit | (violated ? kSafeLayerInfeasible : 0u) | (limit || limit2 ? kSafeLayerIterationLimit : 0u);
  return R;
}

}  // namespace

Result solve(int m, int k, const double* g, const double* h, const double* a_pi, double* a, double* mult, Scratch& S,
             const Options& opt) {
  if (m == 2) return solve_m<2>(m, k, g, h, a_pi, a, mult, S, opt);
  if (m == 1) return solve_m<1>(m, k, g, h, a_pi, a, mult, S, opt);
  return solve_m<0>(m, k, g, h, a_pi, a, mult, S, opt);
}

}  // namespace atacom::safelayer_qp
