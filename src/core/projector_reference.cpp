// The per-env reference: builds J_u = [J_G, A] explicitly and uses its
// pseudo-inverse, exactly as the paper writes the projector. O((m + k)^3).
#include "src/core/projector_reference.hpp"

#include <cmath>
#include <stdexcept>

namespace atacom {

namespace {

bool all_finite(const Eigen::MatrixXd& x) { return x.allFinite(); }

// Orthonormal basis of null(J) (columns), from a full SVD with the usual
// rank tolerance max(sigma) * eps * max(rows, cols).
Eigen::MatrixXd null_space(const Eigen::MatrixXd& J) {
  const Eigen::Index cols = J.cols();
  if (J.rows() == 0) return Eigen::MatrixXd::Identity(cols, cols);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(J, Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  const double tol = (sv.size() ? sv(0) : 0.0) * std::numeric_limits<double>::epsilon() *
                     static_cast<double>(std::max(J.rows(), J.cols()));
  Eigen::Index rank = 0;
  for (Eigen::Index i = 0; i < sv.size(); ++i) rank += sv(i) > tol;
  return svd.matrixV().rightCols(cols - rank);
}

}  // namespace

ReferenceOutput project_reference(const ProjectorModel& model, const ReferenceInput& in) {
  model.validate();
  const int n = model.n, m = model.m, k = model.k, p = model.p;
  if (in.G.rows() != n || in.G.cols() != m || in.c.size() != k || in.Jq.rows() != k || in.Jq.cols() != n ||
      in.alpha.size() != m || (model.has_drift && in.f.size() != n) ||
      (p > 0 && (in.Jx.rows() != k || in.Jx.cols() != p || in.xdot.size() != p)))
    throw std::invalid_argument("project_reference: input shapes do not match the model");

  ReferenceOutput out;
  out.slack_u = Eigen::VectorXd::Zero(k);
  out.s = Eigen::VectorXd::Zero(k);

  // Policy action: clipped to [-1, 1]; NaN/Inf become 0 (pure correction).
  Eigen::VectorXd alpha = in.alpha;
  for (int j = 0; j < m; ++j) {
    if (!std::isfinite(alpha(j))) {
      alpha(j) = 0.0;
      out.status |= kStatusAlphaNonFinite;
    }
    alpha(j) = std::clamp(alpha(j), -1.0, 1.0);
  }

  // Columns of the slack block: one per inequality row.
  std::vector<int> slack_col(k, -1);
  int k_ineq = 0;
  for (int i = 0; i < k; ++i)
    if (!model.equality[i]) slack_col[i] = k_ineq++;

  const Eigen::MatrixXd JG = in.Jq * in.G;
  Eigen::VectorXd F = Eigen::VectorXd::Zero(k);
  if (model.has_drift) F += in.Jq * in.f;
  if (p > 0) F += in.Jx * in.xdot;

  Eigen::MatrixXd Ju = Eigen::MatrixXd::Zero(k, m + k_ineq);
  Ju.leftCols(m) = JG;
  Eigen::VectorXd cbar(k);
  for (int i = 0; i < k; ++i) {
    if (model.equality[i]) {
      cbar(i) = in.c(i);
      continue;
    }
    const double s = slack_value(in.c(i), model.tol[i]);
    out.s(i) = s;
    Ju(i, m + slack_col[i]) = slack_rate(model.slack[i], s, model.beta[i], model.tol[i]);
    cbar(i) = in.c(i) + s;
  }
  out.rhs = F + model.K_c * cbar;
  out.Ju = Ju;

  const bool finite = all_finite(Ju) && all_finite(out.rhs) && (!model.has_drift || all_finite(in.f)) &&
                      all_finite(in.G) && all_finite(in.c);
  if (!finite) {
    out.status |= kStatusModelNonFinite;
    out.a = Eigen::VectorXd::Zero(m);
    out.slack_u.setZero();
    out.lambda = 0.0;
    out.N = Eigen::MatrixXd::Zero(m + k_ineq, m);
    out.b = Eigen::VectorXd::Zero(m + k_ineq);
    return out;
  }

  const Eigen::Index dim = m + k_ineq;
  const Eigen::MatrixXd Jpinv = Ju.completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::MatrixXd Z = Eigen::MatrixXd::Identity(dim, m);
  if (model.basis == BasisType::Projected) {
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(dim, dim) - Jpinv * Ju;
    out.N = P * Z;
  } else {
    // Orthogonal Procrustes: the orthonormal null-space basis U Q closest to Z.
    const Eigen::MatrixXd U = null_space(Ju);
    if (U.cols() == 0) {
      out.N = Eigen::MatrixXd::Zero(dim, m);
    } else {
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(U.transpose() * Z, Eigen::ComputeThinU | Eigen::ComputeThinV);
      out.N = U * (svd.matrixU() * svd.matrixV().transpose());
    }
  }
  out.b = -Jpinv * out.rhs;

  const Eigen::VectorXd t = out.N.topRows(m) * alpha;
  const Eigen::VectorXd b = out.b.head(m);
  bool bias_out = false;
  out.lambda = tangent_scale(b.data(), t.data(), m, &bias_out);
  if (bias_out) out.status |= kStatusBiasOutOfBounds;
  Eigen::VectorXd us = out.b.tail(k_ineq) + out.lambda * (out.N.bottomRows(k_ineq) * alpha);
  if (bias_out && model.bounds == BoundRule::CorrectionFirst) {
    // The correction scaled into the box as a whole; the slack controls
    // still satisfy every row exactly, J_G a + A u_s = -r.
    out.a = b / b.cwiseAbs().maxCoeff();
    const Eigen::VectorXd resid = out.rhs + JG * out.a;
    for (int i = 0; i < k; ++i)
      if (slack_col[i] >= 0) us(slack_col[i]) = -resid(i) / Ju(i, m + slack_col[i]);
  } else {
    out.a = b + out.lambda * t;
  }
  for (int i = 0; i < k; ++i)
    if (slack_col[i] >= 0) out.slack_u(i) = us(slack_col[i]);
  return out;
}

}  // namespace atacom
