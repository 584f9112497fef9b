// The projector's general path, one env at a time with Eigen
// (kernels/projector_general.hpp); the algebra is the lane kernel's
// (kernels/projector_kernel.cpp, its header comment) plus the equality rows.
#include "kernels/projector_general.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>

namespace atacom {

namespace {

inline bool finite(double x) { return std::isfinite(x); }

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


// The calling thread's scratch behind a call that is never inlined (see
// thread_scratch in kernels/projector_kernel.cpp for why).
[[gnu::noinline]] GeneralScratch& general_scratch() {
  thread_local GeneralScratch scratch;
  return scratch;
}

}  // namespace

void project_general_range(const ProjectorModel& mod, ProjectorBatch& B, int begin, int end, bool store_basis,
                           bool store_slack) {
  GeneralScratch& scratch = general_scratch();
  scratch.setup(mod);
  for (int e = begin; e < end; ++e) project_general_one(mod, B, e, scratch, store_basis, store_slack);
}

}  // namespace atacom
