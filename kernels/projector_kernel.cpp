// Batched ATACOM projector.
//
// Fast path (inequality rows, projected basis): blocks of kLanes envs are
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
//   k n m (J_G, dense G) + k m (m + 1) (QR and rhs) + 2 k m (u_s) + O(m^2).
//
// General path (equality rows or smooth basis): the same m x m algebra per env
// with Eigen, plus the k_e x k_e Schur complement of the equality rows and,
// for the smooth basis, N_a^{1/2} (the action block of the Procrustes basis).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include <Eigen/Dense>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"

namespace atacom {

namespace {

constexpr int kLanes = 8;        // one AVX-512 register of doubles
constexpr int kBlockEnvs = 256;  // envs per parallel task (thread-count independent)

// exp(x) with a degree-13 Taylor polynomial after range reduction to
// |r| <= ln2/2: relative error below 2e-16, written so that GCC vectorises it
// across lanes (std::exp stays a scalar libm call). Arguments are clamped to
// [-708, 709]; callers cap the result anyway.
inline double exp_lane(double x) {
  x = x < -708.0 ? -708.0 : (x > 709.0 ? 709.0 : x);
  const double kLog2e = 1.4426950408889634;
  const double kLn2Hi = 6.93147180369123816490e-01;
  const double kLn2Lo = 1.90821492927058770002e-10;
  const double kShift = 6755399441055744.0;  // 1.5 * 2^52: round to nearest
  const double t = x * kLog2e + kShift;
  const double nf = t - kShift;
  const double r = (x - nf * kLn2Hi) - nf * kLn2Lo;
  double p = 1.0 / 6227020800.0;
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
  // 2^n through the exponent bits; n in [-1022, 1023] after the clamp
  // (x = -708 gives n = -1021).
  const int64_t n = std::bit_cast<int64_t>(t) - std::bit_cast<int64_t>(kShift);
  const double scale = std::bit_cast<double>(static_cast<uint64_t>(n + 1023) << 52);
  return p * scale;
}

inline bool finite(double x) { return std::isfinite(x); }

// Lane-major scratch for one block; sized once per thread and model shape.
struct LaneScratch {
  std::vector<double> buf;
  int n = -1, m = -1, k = -1, p = -1;
  double *JqT, *JxT, *GT, *fT, *xdT, *JG, *Bc, *c, *s, *rate, *r, *y, *R, *z, *alpha, *b, *t, *a, *us;

  void setup(const ProjectorModel& mod) {
    if (mod.n == n && mod.m == m && mod.k == k && mod.p == p) return;
    n = mod.n; m = mod.m; k = mod.k; p = mod.p;
    const size_t sizes[] = {
        size_t(k) * n, size_t(k) * p, size_t(n) * m, size_t(n), size_t(p), size_t(k) * m, size_t(k) * m,
        size_t(k), size_t(k), size_t(k), size_t(k), size_t(k), size_t(m) * m, size_t(m), size_t(m), size_t(m),
        size_t(m), size_t(m), size_t(k)};
    size_t total = 0;
    for (size_t sz : sizes) total += sz * kLanes;
    buf.assign(total, 0.0);
    double* ptr = buf.data();
    double** fields[] = {&JqT, &JxT, &GT, &fT, &xdT, &JG, &Bc, &c, &s, &rate, &r, &y, &R, &z, &alpha, &b, &t, &a, &us};
    for (size_t i = 0; i < std::size(fields); ++i) {
      *fields[i] = ptr;
      ptr += sizes[i] * kLanes;
    }
  }
};

// Fast path over envs [lo, hi), hi - lo <= kLanes.
void project_lanes(const ProjectorModel& mod, ProjectorBatch& B, int lo, int hi, LaneScratch& S, bool store_basis) {
  constexpr int L = kLanes;
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  const bool diagG = mod.g_form == GForm::Diagonal;
  const bool need_JqT = !diagG || mod.has_drift;
  const int gsz = diagG ? n : n * m;

  // ---- gather: env-major inputs -> lane-major scratch. Idle lanes repeat the last env.
  for (int l = 0; l < L; ++l) {
    const int e = std::min(lo + l, hi - 1);
    const double* Jq = B.Jq.data() + size_t(e) * k * n;
    const double* G = B.G.data() + size_t(e) * gsz;
    if (need_JqT)
      for (int idx = 0; idx < k * n; ++idx) S.JqT[idx * L + l] = Jq[idx];
    if (diagG) {
      // J_G = J_q diag(g): scale columns while transposing.
      for (int i = 0; i < k; ++i)
        for (int j = 0; j < m; ++j) S.JG[(i * m + j) * L + l] = Jq[i * n + j] * G[j];
    } else {
      for (int idx = 0; idx < n * m; ++idx) S.GT[idx * L + l] = G[idx];
    }
    if (mod.has_drift) {
      const double* f = B.f.data() + size_t(e) * n;
      for (int t = 0; t < n; ++t) S.fT[t * L + l] = f[t];
    }
    if (p > 0) {
      const double* Jx = B.Jx.data() + size_t(e) * k * p;
      const double* xd = B.xdot.data() + size_t(e) * p;
      for (int idx = 0; idx < k * p; ++idx) S.JxT[idx * L + l] = Jx[idx];
      for (int t = 0; t < p; ++t) S.xdT[t * L + l] = xd[t];
    }
    const double* c = B.c.data() + size_t(e) * k;
    for (int i = 0; i < k; ++i) S.c[i * L + l] = c[i];
    const double* al = B.alpha.data() + size_t(e) * m;
    for (int j = 0; j < m; ++j) S.alpha[j * L + l] = al[j];
  }

  // ---- alpha: NaN/Inf -> 0 (flagged), then clip to [-1, 1].
  uint32_t status[L] = {};
  for (int j = 0; j < m; ++j) {
    double* al = S.alpha + j * L;
    for (int l = 0; l < L; ++l) {
      const bool bad = !finite(al[l]);
      status[l] |= bad ? kStatusAlphaNonFinite : 0u;
      const double v = bad ? 0.0 : al[l];
      al[l] = v < -1.0 ? -1.0 : (v > 1.0 ? 1.0 : v);
    }
  }

  // ---- J_G = J_q G (dense G).
  if (!diagG) {
    for (int i = 0; i < k; ++i) {
      for (int j = 0; j < m; ++j) {
        double acc[L] = {};
        for (int t = 0; t < n; ++t) {
          const double* jq = S.JqT + (i * n + t) * L;
          const double* gg = S.GT + (t * m + j) * L;
          for (int l = 0; l < L; ++l) acc[l] += jq[l] * gg[l];
        }
        double* out = S.JG + (i * m + j) * L;
        for (int l = 0; l < L; ++l) out[l] = acc[l];
      }
    }
  }

  // ---- slack, rate, weights, residual r = F + K_c cbar.
  const double Kc = mod.K_c;
  for (int i = 0; i < k; ++i) {
    const double tol = mod.tol[i], beta = mod.beta[i];
    const double cap = 1.0 / tol;
    const double* c = S.c + i * L;
    double* s = S.s + i * L;
    double* rate = S.rate + i * L;
    double* r = S.r + i * L;
    double F[L] = {};
    if (mod.has_drift)
      for (int t = 0; t < n; ++t) {
        const double* jq = S.JqT + (i * n + t) * L;
        const double* f = S.fT + t * L;
        for (int l = 0; l < L; ++l) F[l] += jq[l] * f[l];
      }
    for (int t = 0; t < p; ++t) {
      const double* jx = S.JxT + (i * p + t) * L;
      const double* xd = S.xdT + t * L;
      for (int l = 0; l < L; ++l) F[l] += jx[l] * xd[l];
    }
    for (int l = 0; l < L; ++l) s[l] = -c[l] > tol ? -c[l] : tol;
    switch (mod.slack[i]) {
      case SlackType::SoftCorner:
        for (int l = 0; l < L; ++l) {
          const double e = exp_lane(beta * s[l]);
          rate[l] = (e < cap ? e : cap) - 1.0;
        }
        break;
      case SlackType::Exponential:
        for (int l = 0; l < L; ++l) rate[l] = beta * s[l];
        break;
      case SlackType::Quadratic:
        for (int l = 0; l < L; ++l) rate[l] = std::sqrt(2.0 * s[l]);
        break;
    }
    for (int l = 0; l < L; ++l) r[l] = F[l] + Kc * (c[l] + s[l]);
    // Row-scaled B = A^-1 J_G (stored column-major for the QR below), y = A^-1 r.
    double inv[L];
    for (int l = 0; l < L; ++l) inv[l] = 1.0 / rate[l];
    for (int j = 0; j < m; ++j) {
      const double* jg = S.JG + (i * m + j) * L;
      double* bc = S.Bc + (size_t(j) * k + i) * L;
      for (int l = 0; l < L; ++l) bc[l] = jg[l] * inv[l];
    }
    double* y = S.y + i * L;
    for (int l = 0; l < L; ++l) y[l] = r[l] * inv[l];
  }

  // ---- QR of the stacked [I_m; B] by m Householder reflections, so that
  // M = I + J_G^T W J_G = R^T R is never formed: forming M squares the
  // condition number (W reaches 1/tol^2 on active rows); the QR keeps it.
  // Row j of the identity block is untouched until reflection j, so each
  // reflector has the form v = [1 + |x|; x_B] with x = [1; B(:, j)].
  // The same reflections applied to [0; y] give z with J_G^T W r = R^T z.
  for (int j = 0; j < m; ++j) {
    const double* xb = S.Bc + size_t(j) * k * L;
    double nrm[L], v0[L], tau[L];
    for (int l = 0; l < L; ++l) nrm[l] = 1.0;
    for (int i = 0; i < k; ++i)
      for (int l = 0; l < L; ++l) nrm[l] += xb[i * L + l] * xb[i * L + l];
    for (int l = 0; l < L; ++l) {
      nrm[l] = std::sqrt(nrm[l]);
      v0[l] = 1.0 + nrm[l];
      tau[l] = 1.0 / (nrm[l] * v0[l]);  // 2 / (v^T v), v^T v = 2 |x| (|x| + 1)
      S.R[(j * m + j) * L + l] = -nrm[l];
    }
    auto reflect = [&](double* col, double* top) {  // col: k lanes-vectors below the identity block
      double dot[L] = {};
      for (int i = 0; i < k; ++i)
        for (int l = 0; l < L; ++l) dot[l] += xb[i * L + l] * col[i * L + l];
      for (int l = 0; l < L; ++l) {
        dot[l] *= tau[l];
        top[l] = -dot[l] * v0[l];
      }
      for (int i = 0; i < k; ++i)
        for (int l = 0; l < L; ++l) col[i * L + l] -= dot[l] * xb[i * L + l];
    };
    for (int cc = j + 1; cc < m; ++cc) reflect(S.Bc + size_t(cc) * k * L, S.R + (j * m + cc) * L);
    reflect(S.y, S.z + j * L);
  }

  // R^-1 x and R^-T x in place, lane-wise (R upper triangular, row-major).
  auto solve_R = [&](double* x) {
    for (int i = m - 1; i >= 0; --i) {
      double* xi = x + i * L;
      for (int q = i + 1; q < m; ++q) {
        const double* riq = S.R + (i * m + q) * L;
        const double* xq = x + q * L;
        for (int l = 0; l < L; ++l) xi[l] -= riq[l] * xq[l];
      }
      const double* rii = S.R + (i * m + i) * L;
      for (int l = 0; l < L; ++l) xi[l] /= rii[l];
    }
  };
  auto solve_RT = [&](double* x) {
    for (int i = 0; i < m; ++i) {
      double* xi = x + i * L;
      for (int q = 0; q < i; ++q) {
        const double* rqi = S.R + (q * m + i) * L;
        const double* xq = x + q * L;
        for (int l = 0; l < L; ++l) xi[l] -= rqi[l] * xq[l];
      }
      const double* rii = S.R + (i * m + i) * L;
      for (int l = 0; l < L; ++l) xi[l] /= rii[l];
    }
  };
  // b = -M^-1 J_G^T W r = -R^-1 z;  t = N_a alpha = R^-1 R^-T alpha.
  for (int j = 0; j < m; ++j)
    for (int l = 0; l < L; ++l) {
      S.b[j * L + l] = -S.z[j * L + l];
      S.t[j * L + l] = S.alpha[j * L + l];
    }
  solve_R(S.b);
  solve_RT(S.t);
  solve_R(S.t);

  // ---- lambda: largest scale of the tangential part keeping a in [-1, 1]^m.
  double lam[L];
  bool bias_out[L];
  for (int l = 0; l < L; ++l) { lam[l] = 1.0; bias_out[l] = false; }
  for (int j = 0; j < m; ++j) {
    const double* b = S.b + j * L;
    const double* t = S.t + j * L;
    for (int l = 0; l < L; ++l) {
      bias_out[l] = bias_out[l] || b[l] > 1.0 || b[l] < -1.0;
      const double lim = t[l] > 0.0 ? (1.0 - b[l]) / t[l] : (t[l] < 0.0 ? (-1.0 - b[l]) / t[l] : 1.0);
      lam[l] = lim < lam[l] ? lim : lam[l];
    }
  }
  for (int l = 0; l < L; ++l) {
    if (bias_out[l] || !(lam[l] > 0.0)) lam[l] = 0.0;
    status[l] |= bias_out[l] ? kStatusBiasOutOfBounds : 0u;
  }
  for (int j = 0; j < m; ++j)
    for (int l = 0; l < L; ++l) S.a[j * L + l] = S.b[j * L + l] + lam[l] * S.t[j * L + l];

  // ---- slack controls u_s = -(r + J_G a) / rate.
  bool ok[L];
  for (int l = 0; l < L; ++l) ok[l] = true;
  for (int i = 0; i < k; ++i) {
    double acc[L];
    const double* r = S.r + i * L;
    for (int l = 0; l < L; ++l) acc[l] = r[l];
    for (int j = 0; j < m; ++j) {
      const double* jg = S.JG + (i * m + j) * L;
      const double* a = S.a + j * L;
      for (int l = 0; l < L; ++l) acc[l] += jg[l] * a[l];
    }
    const double* rate = S.rate + i * L;
    double* us = S.us + i * L;
    for (int l = 0; l < L; ++l) {
      us[l] = -acc[l] / rate[l];
      ok[l] = ok[l] && finite(us[l]);
    }
  }
  for (int j = 0; j < m; ++j)
    for (int l = 0; l < L; ++l) ok[l] = ok[l] && finite(S.a[j * L + l]);

  // ---- scatter back to env-major outputs.
  for (int l = 0; l < hi - lo; ++l) {
    const int e = lo + l;
    double* a = B.a.data() + size_t(e) * m;
    double* us = B.slack_u.data() + size_t(e) * k;
    double* s = B.s.data() + size_t(e) * k;
    if (ok[l]) {
      for (int j = 0; j < m; ++j) a[j] = S.a[j * L + l];
      for (int i = 0; i < k; ++i) us[i] = S.us[i * L + l];
      B.lambda[e] = lam[l];
    } else {
      // Non-finite model (NaN/Inf in f, G, c, J or xdot): stop.
      for (int j = 0; j < m; ++j) a[j] = 0.0;
      for (int i = 0; i < k; ++i) us[i] = 0.0;
      B.lambda[e] = 0.0;
      status[l] |= kStatusModelNonFinite;
    }
    for (int i = 0; i < k; ++i) s[i] = S.s[i * L + l];
    B.status[e] = status[l];
  }

  if (store_basis) {
    // N_a = M^-1, one column per unit right-hand side.
    for (int col = 0; col < m; ++col) {
      for (int j = 0; j < m; ++j)
        for (int l = 0; l < L; ++l) S.t[j * L + l] = j == col ? 1.0 : 0.0;
      solve_RT(S.t);
      solve_R(S.t);
      for (int l = 0; l < hi - lo; ++l) {
        double* Na = B.Na.data() + size_t(lo + l) * m * m;
        for (int j = 0; j < m; ++j) Na[j * m + col] = S.t[j * L + l];
      }
    }
  }
}

// Per-env scratch for the general path (equality rows / smooth basis).
struct GeneralScratch {
  Eigen::MatrixXd JG, Jq, G, stack, Rinv, Minv, JE, S, Na, T;
  Eigen::VectorXd F, r, rate, rhs, z, alpha, b, t, a, rE, mu;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
};

// Symmetric PSD (pseudo-)square root and (pseudo-)inverse through one
// eigen-decomposition; eigenvalues below rel * max are treated as zero.
void psd_functions(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eig, const Eigen::MatrixXd& X, double rel,
                   Eigen::MatrixXd* sqrt_out, Eigen::MatrixXd* pinv_out, bool* rank_loss) {
  eig.compute(X);
  const Eigen::VectorXd& ev = eig.eigenvalues();
  const Eigen::MatrixXd& V = eig.eigenvectors();
  const double emax = ev.size() ? std::max(ev.maxCoeff(), 0.0) : 0.0;
  const double thr = emax * rel;
  Eigen::VectorXd sq(ev.size()), inv(ev.size());
  bool loss = false;
  for (Eigen::Index i = 0; i < ev.size(); ++i) {
    const bool pos = ev(i) > thr && ev(i) > 0.0;
    loss = loss || !pos;
    sq(i) = pos ? std::sqrt(ev(i)) : 0.0;
    inv(i) = pos ? 1.0 / ev(i) : 0.0;
  }
  if (sqrt_out) *sqrt_out = V * sq.asDiagonal() * V.transpose();
  if (pinv_out) *pinv_out = V * inv.asDiagonal() * V.transpose();
  if (rank_loss) *rank_loss = loss;
}

void project_general_one(const ProjectorModel& mod, ProjectorBatch& B, int e, GeneralScratch& W, bool store_basis) {
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  uint32_t status = 0;
  W.alpha.resize(m);
  const double* al = B.alpha.data() + size_t(e) * m;
  for (int j = 0; j < m; ++j) {
    double v = al[j];
    if (!finite(v)) { v = 0.0; status |= kStatusAlphaNonFinite; }
    W.alpha(j) = std::clamp(v, -1.0, 1.0);
  }
  W.Jq = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(B.Jq.data() + size_t(e) * k * n, k, n);
  if (mod.g_form == GForm::Diagonal) {
    W.JG = W.Jq * Eigen::Map<const Eigen::VectorXd>(B.G.data() + size_t(e) * n, n).asDiagonal();
  } else {
    W.G = Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(B.G.data() + size_t(e) * n * m, n, m);
    W.JG = W.Jq * W.G;
  }
  W.F = Eigen::VectorXd::Zero(k);
  if (mod.has_drift) W.F += W.Jq * Eigen::Map<const Eigen::VectorXd>(B.f.data() + size_t(e) * n, n);
  if (p > 0)
    W.F += Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(B.Jx.data() + size_t(e) * k * p, k, p) *
           Eigen::Map<const Eigen::VectorXd>(B.xdot.data() + size_t(e) * p, p);

  const double* c = B.c.data() + size_t(e) * k;
  double* s_out = B.s.data() + size_t(e) * k;
  W.r.resize(k);
  W.rate.resize(k);
  const int ke = mod.num_equality();
  const int ki = k - ke;
  W.JE.resize(ke, m);
  W.rE.resize(ke);
  // [I; A^-1 J_I] and [0; A^-1 r_I]: their QR gives I + J_I^T W J_I = R^T R
  // and J_I^T W r_I = R^T z without forming the products (as in the fast path).
  W.stack.setZero(m + ki, m);
  W.stack.topRows(m).setIdentity();
  W.rhs.setZero(m + ki);
  for (int i = 0, ie = 0, ii = 0; i < k; ++i) {
    if (mod.equality[i]) {
      s_out[i] = 0.0;
      W.r(i) = W.F(i) + mod.K_c * c[i];
      W.JE.row(ie) = W.JG.row(i);
      W.rE(ie++) = W.r(i);
      continue;
    }
    const double s = slack_value(c[i], mod.tol[i]);
    s_out[i] = s;
    W.rate(i) = slack_rate(mod.slack[i], s, mod.beta[i], mod.tol[i]);
    W.r(i) = W.F(i) + mod.K_c * (c[i] + s);
    W.stack.row(m + ii) = W.JG.row(i) / W.rate(i);
    W.rhs(m + ii++) = W.r(i) / W.rate(i);
  }

  double* a_out = B.a.data() + size_t(e) * m;
  double* us_out = B.slack_u.data() + size_t(e) * k;
  const bool model_ok = W.stack.allFinite() && W.rhs.allFinite() && W.r.allFinite() && W.JE.allFinite();
  if (model_ok) {
    W.qr.compute(W.stack);
    W.z = (W.qr.householderQ().transpose() * W.rhs).head(m);
    const auto R = W.qr.matrixQR().topRows(m).triangularView<Eigen::Upper>();
    W.Rinv = R.solve(Eigen::MatrixXd::Identity(m, m));
    W.Minv = W.Rinv * W.Rinv.transpose();
    W.b = -(W.Rinv * W.z);
    const Eigen::VectorXd g = R.transpose() * W.z;  // J_I^T W r_I
    if (ke > 0) {
      // Equality rows: the tangent space is restricted to null(J_E) in the
      // M-metric. S = J_E M^-1 J_E^T; dependent rows are solved in least squares.
      W.S = W.JE * W.Minv * W.JE.transpose();
      Eigen::MatrixXd Spinv;
      bool loss = false;
      psd_functions(W.eig, W.S, 1e-12, nullptr, &Spinv, &loss);
      if (loss) status |= kStatusEqualityRankLoss;
      const Eigen::MatrixXd MJ = W.Minv * W.JE.transpose();  // (m x ke)
      W.Na = W.Minv - MJ * Spinv * MJ.transpose();
      W.mu = Spinv * (W.JE * W.Minv * g - W.rE);
      W.b = W.Minv * (W.JE.transpose() * W.mu - g);
    } else {
      W.Na = W.Minv;
    }
    if (mod.basis == BasisType::Smooth) {
      // Action block of the Procrustes basis: N_a^{1/2} (see docs/projector.md).
      psd_functions(W.eig, W.Na, 1e-13, &W.T, nullptr, nullptr);
    } else {
      W.T = W.Na;
    }
    W.t = W.T * W.alpha;
    bool bias_out = false;
    const double lam = tangent_scale(W.b.data(), W.t.data(), m, &bias_out);
    if (bias_out) status |= kStatusBiasOutOfBounds;
    W.a = W.b + lam * W.t;
    bool ok = W.a.allFinite();
    for (int i = 0; i < k; ++i) {
      if (mod.equality[i]) { us_out[i] = 0.0; continue; }
      us_out[i] = -(W.r(i) + W.JG.row(i).dot(W.a)) / W.rate(i);
      ok = ok && finite(us_out[i]);
    }
    if (ok) {
      for (int j = 0; j < m; ++j) a_out[j] = W.a(j);
      B.lambda[e] = lam;
      if (store_basis) Eigen::Map<Eigen::Matrix<double, -1, -1, Eigen::RowMajor>>(B.Na.data() + size_t(e) * m * m, m, m) = W.T;
      B.status[e] = status;
      return;
    }
  }
  for (int j = 0; j < m; ++j) a_out[j] = 0.0;
  for (int i = 0; i < k; ++i) us_out[i] = 0.0;
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

}  // namespace

void project_range(const ProjectorModel& mod, ProjectorBatch& B, int begin, int end, const ProjectOptions& opt) {
  if (begin >= end) return;
  if (opt.store_basis && B.Na.size() != size_t(B.N) * mod.m * mod.m) B.Na.assign(size_t(B.N) * mod.m * mod.m, 0.0);
  const bool fast = mod.num_equality() == 0 && mod.basis == BasisType::Projected;
  if (fast) {
    thread_local LaneScratch scratch;
    scratch.setup(mod);
    for (int lo = begin; lo < end; lo += kLanes) project_lanes(mod, B, lo, std::min(lo + kLanes, end), scratch, opt.store_basis);
  } else {
    thread_local GeneralScratch scratch;
    for (int e = begin; e < end; ++e) project_general_one(mod, B, e, scratch, opt.store_basis);
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
