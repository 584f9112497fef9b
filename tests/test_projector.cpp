// Projector invariants and kernel-vs-reference agreement on random systems.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "src/core/projector_reference.hpp"
#include "atacom/rng.hpp"

using namespace atacom;

namespace {

struct ProblemShape { int n, m, k, p; };

// A random env: J entries ~ N(0, 1), G dense ~ N(0, 1), constraint values
// drawn so rows range from deep inside (c = -3) to violated (c = +0.2), with
// c_min bounding how close to the boundary the safe rows get.
void fill_random(const ProjectorModel& mod, ProjectorBatch& B, int e, Rng& rng, double c_lo = -3.0, double c_hi = 0.2) {
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  for (int i = 0; i < n; ++i) B.f[size_t(e) * n + i] = rng.normal();
  const int gsz = mod.g_form == GForm::Diagonal ? n : n * m;
  for (int i = 0; i < gsz; ++i) B.G[size_t(e) * gsz + i] = mod.g_form == GForm::Diagonal ? rng.uniform(0.2, 2.0) : rng.normal();
  for (int i = 0; i < k; ++i) B.c[size_t(e) * k + i] = rng.uniform(c_lo, c_hi);
  for (int i = 0; i < k * n; ++i) B.Jq[size_t(e) * k * n + i] = rng.normal();
  for (int i = 0; i < k * p; ++i) B.Jx[size_t(e) * k * p + i] = rng.normal();
  for (int i = 0; i < p; ++i) B.xdot[size_t(e) * p + i] = rng.normal();
  for (int i = 0; i < m; ++i) B.alpha[size_t(e) * m + i] = rng.uniform(-1.2, 1.2);
}

ReferenceInput reference_input(const ProjectorModel& mod, const ProjectorBatch& B, int e) {
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  using RM = Eigen::Matrix<double, -1, -1, Eigen::RowMajor>;
  ReferenceInput in;
  in.f = Eigen::Map<const Eigen::VectorXd>(B.f.data() + size_t(e) * n, n);
  if (mod.g_form == GForm::Diagonal)
    in.G = Eigen::Map<const Eigen::VectorXd>(B.G.data() + size_t(e) * n, n).asDiagonal();
  else
    in.G = Eigen::Map<const RM>(B.G.data() + size_t(e) * n * m, n, m);
  in.c = Eigen::Map<const Eigen::VectorXd>(B.c.data() + size_t(e) * k, k);
  in.Jq = Eigen::Map<const RM>(B.Jq.data() + size_t(e) * k * n, k, n);
  in.Jx = Eigen::Map<const RM>(B.Jx.data() + size_t(e) * k * p, k, p);
  in.xdot = Eigen::Map<const Eigen::VectorXd>(B.xdot.data() + size_t(e) * p, p);
  in.alpha = Eigen::Map<const Eigen::VectorXd>(B.alpha.data() + size_t(e) * m, m);
  return in;
}

// max |x| that is 0 for empty matrices (Eigen's maxCoeff needs size > 0).
template <class M>
double amax(const M& x) { return x.size() ? double(x.cwiseAbs().maxCoeff()) : 0.0; }

double max_abs_diff(const double* x, const double* y, int n) {
  double d = 0;
  for (int i = 0; i < n; ++i) d = std::max(d, std::abs(x[i] - y[i]));
  return d;
}

ProjectorModel random_model(Rng& rng, ProblemShape sh) {
  ProjectorModel mod = default_projector_model(sh.n, sh.m, sh.k, sh.p);
  for (int i = 0; i < sh.k; ++i) {
    mod.slack[i] = static_cast<SlackType>(rng.below(3));
    mod.beta[i] = rng.uniform(0.5, 30.0);
    mod.tol[i] = std::pow(10.0, -rng.uniform(3.0, 7.0));
  }
  mod.K_c = rng.uniform(0.0, 60.0);
  return mod;
}

const ProblemShape kShapes[] = {{1, 1, 1, 0}, {2, 2, 1, 0}, {3, 2, 5, 2}, {4, 2, 3, 0}, {7, 7, 34, 0},
                         {7, 7, 5, 3}, {6, 3, 12, 4}, {2, 2, 9, 1}, {14, 7, 20, 0}, {5, 5, 0, 0}};

}  // namespace

TEST_CASE("projector: fast kernel equals the per-env reference", "[projector]") {
  Rng rng(42, 0);
  for (const ProblemShape& sh : kShapes) {
    for (int variant = 0; variant < 4; ++variant) {
      const int gform = variant & 1;
      if (gform == 1 && sh.n != sh.m) continue;
      ProjectorModel mod = random_model(rng, sh);
      mod.g_form = gform ? GForm::Diagonal : GForm::Dense;
      // Variants 2 and 3: the smooth basis, whose action block N_a^{1/2} the
      // lane kernel gets from a per-lane Jacobi eigen-decomposition.
      mod.basis = variant >= 2 ? BasisType::Smooth : BasisType::Projected;
      mod.has_drift = rng.below(2) == 1;
      const int N = 37;  // not a multiple of the lane count: exercises the tail block
      ProjectorBatch B(mod, N);
      // Keep rows at least 0.05 from the boundary so both implementations see
      // a well-conditioned J_u (slack rates >= 0.025); the boundary and
      // violated cases, where the two agree to the conditioning, have their own test.
      for (int e = 0; e < N; ++e) fill_random(mod, B, e, rng, -3.0, -0.05);
      project_batch(mod, B, {.store_basis = true});
      for (int e = 0; e < N; ++e) {
        const ReferenceOutput ref = project_reference(mod, reference_input(mod, B, e));
        INFO("shape n=" << sh.n << " m=" << sh.m << " k=" << sh.k << " p=" << sh.p << " variant " << variant
                          << " env " << e);
        const double scale = 1.0 + amax(ref.b.head(sh.m));
        CHECK(max_abs_diff(B.a.data() + size_t(e) * sh.m, ref.a.data(), sh.m) <= 1e-12 * scale);
        CHECK(max_abs_diff(B.s.data() + size_t(e) * sh.k, ref.s.data(), sh.k) == 0.0);
        CHECK(std::abs(B.lambda[e] - ref.lambda) <= 1e-12);
        CHECK(B.status[e] == ref.status);
        // The action block of the basis: (I + J_G^T A^-2 J_G)^-1 (push-through) == top of N,
        // or its square root for the smooth basis.
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>> Na(B.Na.data() + size_t(e) * sh.m * sh.m,
                                                                            sh.m, sh.m);
        CHECK(amax(Na - ref.N.topRows(sh.m)) <= 1e-12);
        // Slack controls agree relative to their size (they scale like 1/rate).
        const double us_scale = 1.0 + (sh.k ? amax(ref.slack_u) : 0.0);
        CHECK(max_abs_diff(B.slack_u.data() + size_t(e) * sh.k, ref.slack_u.data(), sh.k) <= 1e-10 * us_scale);
      }
    }
  }
}

TEST_CASE("projector: tangent basis annihilates J_u and the control keeps dc/dt on the manifold", "[projector]") {
  Rng rng(7, 1);
  for (const ProblemShape& sh : kShapes) {
    for (int basis = 0; basis < 2; ++basis) {
      ProjectorModel mod = random_model(rng, sh);
      mod.basis = basis ? BasisType::Smooth : BasisType::Projected;
      ProjectorBatch B(mod, 20);
      for (int e = 0; e < 20; ++e) fill_random(mod, B, e, rng, -3.0, 0.2);
      for (int e = 0; e < 20; ++e) {
        const ReferenceInput in = reference_input(mod, B, e);
        const ReferenceOutput ref = project_reference(mod, in);
        INFO("shape n=" << sh.n << " m=" << sh.m << " k=" << sh.k << " basis " << basis);
        const double jscale = 1.0 + amax(ref.Ju);
        CHECK(amax(ref.Ju * ref.N) <= 1e-10 * jscale);
        if (mod.basis == BasisType::Smooth)
          CHECK(amax(ref.N.transpose() * ref.N - Eigen::MatrixXd::Identity(sh.m, sh.m)) <= 1e-10);
        // With lambda = 1 (unscaled), J_u [a; u_s] = -(F + K_c cbar); residual
        // relative to the size of the terms that cancel.
        Eigen::VectorXd alpha = in.alpha.cwiseMax(-1.0).cwiseMin(1.0);
        Eigen::VectorXd full = ref.N * alpha + ref.b;
        const double rscale = 1.0 + amax(ref.rhs) + amax(ref.Ju.cwiseAbs() * full.cwiseAbs());
        CHECK(amax(ref.Ju * full + ref.rhs) <= 1e-10 * rscale);
      }
      // The kernel: its basis [N_a; -A^-1 J_G N_a] (projected) or
      // [N_a^1/2; -A^-1 J_G N_a^1/2] (smooth) annihilates J_u, and its output
      // satisfies J_u [a; u_s] = -(F + K_c cbar) whatever lambda it chose.
      project_batch(mod, B, {.store_basis = true});
      for (int e = 0; e < 20; ++e) {
        const ReferenceOutput ref = project_reference(mod, reference_input(mod, B, e));
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>> T(B.Na.data() + size_t(e) * sh.m * sh.m, sh.m, sh.m);
        Eigen::MatrixXd N(sh.m + sh.k, sh.m);
        N.topRows(sh.m) = T;
        const Eigen::MatrixXd JG = ref.Ju.leftCols(sh.m);
        for (int i = 0; i < sh.k; ++i) N.row(sh.m + i) = -(JG.row(i) * T) / ref.Ju(i, sh.m + i);
        CHECK(amax(ref.Ju * N) <= 1e-10 * (1.0 + amax(ref.Ju.cwiseAbs() * N.cwiseAbs())));
        Eigen::VectorXd full(sh.m + sh.k);
        for (int j = 0; j < sh.m; ++j) full(j) = B.a[size_t(e) * sh.m + j];
        for (int i = 0; i < sh.k; ++i) full(sh.m + i) = B.slack_u[size_t(e) * sh.k + i];
        const double scale = 1.0 + amax(ref.rhs) + amax(ref.Ju.cwiseAbs() * full.cwiseAbs());
        CHECK(amax(ref.Ju * full + ref.rhs) <= 1e-10 * scale);
      }
    }
  }
}

TEST_CASE("projector: agreement at and beyond the boundary (slack at its floor)", "[projector]") {
  // Active or violated rows have rate ~ beta * tol, so J_u is badly scaled
  // (condition ~ 1/tol^2); the m x m and the (m + k) forms then agree to that
  // conditioning, not to 1e-12. Both keep a inside the bounds.
  Rng rng(11, 0);
  ProjectorModel mod = default_projector_model(7, 7, 34, 0);
  ProjectorBatch B(mod, 64);
  for (int e = 0; e < 64; ++e) {
    fill_random(mod, B, e, rng, -0.5, 0.0);
    for (int i = 0; i < 34; i += 4) B.c[size_t(e) * 34 + i] = -rng.uniform(0.0, 1e-6);
    for (int i = 1; i < 34; i += 7) B.c[size_t(e) * 34 + i] = rng.uniform(0.0, 0.2);
  }
  project_batch(mod, B);
  for (int e = 0; e < 64; ++e) {
    const ReferenceOutput ref = project_reference(mod, reference_input(mod, B, e));
    CHECK(max_abs_diff(B.a.data() + size_t(e) * 7, ref.a.data(), 7) <= 1e-7);
    // a leaves the box only when the correction b alone does (never scaled), and then it says so.
    const bool flagged = (B.status[e] & kStatusBiasOutOfBounds) != 0;
    CHECK(flagged == ((ref.status & kStatusBiasOutOfBounds) != 0));
    for (int j = 0; j < 7; ++j)
      if (!flagged) CHECK(std::abs(B.a[size_t(e) * 7 + j]) <= 1.0 + 1e-12);
  }
}

TEST_CASE("projector: equality rows (general path) and the smooth basis equal the reference", "[projector]") {
  Rng rng(3, 3);
  const ProblemShape shapes[] = {{3, 3, 4, 0}, {7, 7, 12, 2}, {4, 2, 3, 1}, {6, 4, 8, 0}};
  for (const ProblemShape& sh : shapes) {
    for (int variant = 0; variant < 3; ++variant) {
      ProjectorModel mod = random_model(rng, sh);
      if (variant != 1) {  // equality rows in variants 0 and 2
        mod.equality[0] = 1;
        if (sh.m > 2) mod.equality[sh.k - 1] = 1;
      }
      if (variant >= 1) mod.basis = BasisType::Smooth;
      mod.has_drift = true;
      ProjectorBatch B(mod, 9);
      for (int e = 0; e < 9; ++e) fill_random(mod, B, e, rng, -3.0, -1e-2);
      project_batch(mod, B, {.store_basis = true});
      for (int e = 0; e < 9; ++e) {
        const ReferenceOutput ref = project_reference(mod, reference_input(mod, B, e));
        INFO("shape m=" << sh.m << " k=" << sh.k << " variant " << variant << " env " << e);
        CHECK(max_abs_diff(B.a.data() + size_t(e) * sh.m, ref.a.data(), sh.m) <= 1e-9);
        CHECK(std::abs(B.lambda[e] - ref.lambda) <= 1e-9);
        Eigen::Map<const Eigen::Matrix<double, -1, -1, Eigen::RowMajor>> T(B.Na.data() + size_t(e) * sh.m * sh.m,
                                                                           sh.m, sh.m);
        CHECK(amax(T - ref.N.topRows(sh.m)) <= 1e-9);
        // Equality rows hold exactly to first order: J_E a = -r_E, unless the
        // correction alone left the box and was scaled into it (correction_first).
        for (int i = 0; i < sh.k; ++i) {
          if (!mod.equality[i] || (ref.status & kStatusBiasOutOfBounds)) continue;
          double v = ref.rhs(i);
          for (int j = 0; j < sh.m; ++j) v += ref.Ju(i, j) * B.a[size_t(e) * sh.m + j];
          CHECK(std::abs(v) <= 1e-9 * (1.0 + std::abs(ref.rhs(i))));
        }
      }
    }
  }
}

TEST_CASE("projector: stays finite for zero, rank-deficient and duplicated J_G", "[projector]") {
  Rng rng(5, 0);
  for (int basis = 0; basis < 2; ++basis) {
    ProjectorModel mod = default_projector_model(4, 3, 6, 0);
    mod.basis = basis ? BasisType::Smooth : BasisType::Projected;
    ProjectorBatch B(mod, 3);
    for (int e = 0; e < 3; ++e) fill_random(mod, B, e, rng, -1e-7, 0.0);  // all rows at the boundary
    // env 0: J = 0; env 1: rank 1; env 2: every row the same.
    std::fill_n(B.Jq.begin(), 24, 0.0);
    for (int i = 0; i < 6; ++i)
      for (int t = 0; t < 4; ++t) B.Jq[24 + i * 4 + t] = (i + 1) * (t == 2 ? 1.0 : 0.0);
    for (int i = 0; i < 6; ++i)
      for (int t = 0; t < 4; ++t) B.Jq[48 + i * 4 + t] = B.Jq[48 + t];
    project_batch(mod, B);
    for (double v : B.a) CHECK(std::isfinite(v));
    for (double v : B.slack_u) CHECK(std::isfinite(v));
    for (int e = 0; e < 3; ++e) CHECK((B.status[e] & kStatusModelNonFinite) == 0);
    // J = 0: the constraints cannot be influenced, the action passes through (up to bounds and drift).
    for (int j = 0; j < 3; ++j) {
      double alpha = std::clamp(B.alpha[j], -1.0, 1.0);
      CHECK(B.a[j] == Approx(alpha).margin(1e-12));
    }
  }
  // Dependent equality rows: least squares, flagged, finite.
  ProjectorModel mod = default_projector_model(3, 3, 2, 0);
  mod.equality = {1, 1};
  ProjectorBatch B(mod, 1);
  fill_random(mod, B, 0, rng);
  for (int t = 0; t < 3; ++t) B.Jq[3 + t] = B.Jq[t];
  project_batch(mod, B);
  CHECK((B.status[0] & kStatusEqualityRankLoss) != 0);
  for (double v : B.a) CHECK(std::isfinite(v));
}

TEST_CASE("projector: SoftCorner leaves the action space undistorted far from the boundary", "[projector]") {
  // All rows with s >= 5 / beta: rate >= e^5 - 1, so N_a = I - O(|J_G|^2 / rate^2).
  Rng rng(9, 0);
  ProjectorModel mod = default_projector_model(5, 5, 5, 0);
  mod.K_c = 0.0;
  mod.has_drift = false;
  ProjectorBatch B(mod, 200);
  for (int e = 0; e < 200; ++e) {
    fill_random(mod, B, e, rng);
    for (int i = 0; i < 5; ++i) {
      B.c[size_t(e) * 5 + i] = -rng.uniform(5.0 / mod.beta[i], 3.0);
      // unit-norm constraint gradients, identity G
      double nrm = 0;
      for (int t = 0; t < 5; ++t) nrm += B.Jq[size_t(e) * 25 + i * 5 + t] * B.Jq[size_t(e) * 25 + i * 5 + t];
      for (int t = 0; t < 5; ++t) B.Jq[size_t(e) * 25 + i * 5 + t] /= std::sqrt(nrm);
    }
    for (int t = 0; t < 25; ++t) B.G[size_t(e) * 25 + t] = t % 6 == 0 ? 1.0 : 0.0;
    for (int j = 0; j < 5; ++j) B.alpha[size_t(e) * 5 + j] = rng.uniform(-1.0, 1.0);
  }
  project_batch(mod, B);
  for (int e = 0; e < 200; ++e)
    CHECK(max_abs_diff(B.a.data() + size_t(e) * 5, B.alpha.data() + size_t(e) * 5, 5) <= 1e-3);
}

TEST_CASE("projector: basis is continuous along a smooth path where a QR null space flips", "[projector]") {
  // J_u(theta) for one constraint with gradient rotating through the plane.
  // The projected basis N(theta) must move by O(dtheta) per step; a
  // Householder-QR null space of the same J_u jumps (sign flips).
  ProjectorModel mod = default_projector_model(2, 2, 1, 0);
  mod.beta = {2.0};
  ProjectorBatch B(mod, 1);
  B.G = {1, 0, 0, 1};
  B.c = {-0.05};
  B.alpha = {0.3, -0.4};
  const int steps = 2000;
  double max_jump_proj = 0, max_jump_qr = 0;
  Eigen::MatrixXd prevN, prevQ;
  for (int s = 0; s <= steps; ++s) {
    const double th = 2.0 * M_PI * s / steps;
    B.Jq = {std::cos(th), std::sin(th)};
    project_batch(mod, B, {.store_basis = true});
    ReferenceInput in = reference_input(mod, B, 0);
    const ReferenceOutput ref = project_reference(mod, in);
    Eigen::HouseholderQR<Eigen::MatrixXd> qr(ref.Ju.transpose());
    const Eigen::MatrixXd Q = qr.householderQ();
    const Eigen::MatrixXd nullQ = Q.rightCols(2);
    if (s > 0) {
      max_jump_proj = std::max(max_jump_proj, (ref.N - prevN).cwiseAbs().maxCoeff());
      max_jump_qr = std::max(max_jump_qr, (nullQ - prevQ).cwiseAbs().maxCoeff());
    }
    prevN = ref.N;
    prevQ = nullQ;
  }
  const double dth = 2.0 * M_PI / steps;
  CHECK(max_jump_proj < 10 * dth);  // Lipschitz along the path
  CHECK(max_jump_qr > 0.5);         // the QR basis flips somewhere on the circle
}

TEST_CASE("projector: bounds scale only the tangential part", "[projector]") {
  ProjectorModel mod = default_projector_model(2, 2, 1, 0);
  mod.bounds = BoundRule::TangentScale;  // the rule that hands b to the env
  mod.has_drift = true;
  ProjectorBatch B(mod, 2);
  B.G = {1, 0, 0, 1, 1, 0, 0, 1};
  B.Jq = {1, 0, 1, 0};
  B.c = {-2.0, -1e-6};
  B.f = {0.5, 0.0, 3.0, 0.0};  // env 1: at the boundary, drift so strong that b leaves the box
  B.alpha = {1.0, 1.0, 1.0, 1.0};
  project_batch(mod, B);
  // env 0: b = (-0.5 N-ish, 0), tangential (1, 1) scaled so a stays inside.
  CHECK(B.lambda[0] > 0.0);
  CHECK(B.lambda[0] <= 1.0);
  for (int j = 0; j < 2; ++j) CHECK(std::abs(B.a[j]) <= 1.0 + 1e-12);
  CHECK(B.status[0] == kStatusOk);
  // env 1: b alone is outside: lambda = 0, a = b, flagged.
  CHECK(B.lambda[1] == 0.0);
  CHECK((B.status[1] & kStatusBiasOutOfBounds) != 0);
  CHECK(B.a[2] < -1.0);
}

TEST_CASE("projector: NaN alpha falls back to pure correction, NaN model stops", "[projector]") {
  ProjectorModel mod = default_projector_model(2, 2, 1, 0);
  for (int basis = 0; basis < 2; ++basis) {
    mod.basis = basis ? BasisType::Smooth : BasisType::Projected;
    ProjectorBatch B(mod, 3);
    B.G = {1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1};
    B.Jq = {1, 0, 1, 0, 1, 0};
    B.c = {0.1, -1.0, -1.0};
    B.f = {0, 0, 0, 0, 0, 0};
    B.alpha = {std::nan(""), 0.5, 0.2, 0.2, std::numeric_limits<double>::infinity(), 0.0};
    B.Jq[2] = std::nan("");  // env 1 has a broken Jacobian
    project_batch(mod, B);
    CHECK((B.status[0] & kStatusAlphaNonFinite) != 0);
    CHECK(std::isfinite(B.a[0]));
    CHECK(B.a[0] < 0.0);  // c > 0: correction pushes back
    CHECK((B.status[1] & kStatusModelNonFinite) != 0);
    CHECK(B.a[2] == 0.0);
    CHECK(B.a[3] == 0.0);
    CHECK((B.status[2] & kStatusAlphaNonFinite) != 0);
    CHECK(std::isfinite(B.a[4]));
  }
}

TEST_CASE("projector: results do not depend on the thread count", "[projector]") {
  Rng rng(1, 2);
  for (int basis = 0; basis < 2; ++basis) {
    ProjectorModel mod = default_projector_model(7, 7, 34, 3);
    mod.basis = basis ? BasisType::Smooth : BasisType::Projected;
    ProjectorBatch B1(mod, 3000);
    for (int e = 0; e < 3000; ++e) fill_random(mod, B1, e, rng);
    ProjectorBatch B2 = B1;
    set_num_threads(1);
    project_batch(mod, B1);
    set_num_threads(2);
    project_batch(mod, B2);
    set_num_threads(0);
    CHECK(B1.a == B2.a);
    CHECK(B1.slack_u == B2.slack_u);
    CHECK(B1.lambda == B2.lambda);
  }
}

TEST_CASE("projector: model validation and JSON round trip", "[projector]") {
  ProjectorModel mod = default_projector_model(3, 2, 2, 1);
  mod.slack[1] = SlackType::Quadratic;
  mod.beta[0] = 7.0;
  mod.equality[1] = 1;
  mod.basis = BasisType::Smooth;
  nlohmann::json j = mod;
  ProjectorModel back = j.get<ProjectorModel>();
  CHECK(nlohmann::json(back) == j);
  j["bogus"] = 1;
  CHECK_THROWS_WITH(j.get<ProjectorModel>(), Catch::Contains("bogus"));
  ProjectorModel bad = default_projector_model(3, 2, 2, 0);
  bad.tol[1] = 0.0;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("tol[1]"));
  ProjectorBatch B(mod, 2);
  B.c.resize(1);
  CHECK_THROWS_WITH(project_batch(mod, B), Catch::Contains("sizes"));
}

TEST_CASE("projector: skipping the slack outputs changes nothing else", "[projector]") {
  Rng rng(8, 8);
  for (int variant = 0; variant < 3; ++variant) {
    ProjectorModel mod = default_projector_model(7, 7, 20, 2);
    if (variant == 1) mod.basis = BasisType::Smooth;
    if (variant == 2) mod.equality[3] = 1;
    ProjectorBatch full(mod, 21);
    for (int e = 0; e < 21; ++e) fill_random(mod, full, e, rng);
    ProjectorBatch lean = full;
    std::fill(lean.s.begin(), lean.s.end(), -7.0);
    std::fill(lean.slack_u.begin(), lean.slack_u.end(), -7.0);
    project_batch(mod, full);
    project_batch(mod, lean, {.store_slack = false});
    CHECK(full.a == lean.a);
    CHECK(full.lambda == lean.lambda);
    CHECK(full.status == lean.status);
    for (double v : lean.s) CHECK(v == -7.0);
    for (double v : lean.slack_u) CHECK(v == -7.0);
  }
}

TEST_CASE("projector: correction-first bounds equal the reference and keep a inside the box", "[projector]") {
  Rng rng(31, 5);
  const ProblemShape shapes[] = {{7, 7, 34, 0}, {3, 2, 5, 2}, {4, 3, 6, 1}, {2, 2, 3, 0}};
  int scaled = 0;
  for (const ProblemShape& sh : shapes) {
    for (int variant = 0; variant < 4; ++variant) {
      ProjectorModel mod = random_model(rng, sh);
      for (int i = 0; i < sh.k; ++i) mod.tol[i] = 1e-3;  // agreement to 1e-9 needs a conditioned J_u
      mod.K_c = 30.0;
      mod.bounds = variant % 2 ? BoundRule::CorrectionFirst : BoundRule::TangentScale;
      if (variant >= 2 && sh.k > 1) mod.equality[0] = 1;  // the general path
      const int N = 29;
      ProjectorBatch B(mod, N);
      for (int e = 0; e < N; ++e) fill_random(mod, B, e, rng, -0.3, 0.1);
      project_batch(mod, B);
      for (int e = 0; e < N; ++e) {
        const ReferenceOutput ref = project_reference(mod, reference_input(mod, B, e));
        INFO("shape m=" << sh.m << " k=" << sh.k << " variant " << variant << " env " << e);
        const double scale = 1.0 + amax(ref.b.head(sh.m));
        CHECK(max_abs_diff(B.a.data() + size_t(e) * sh.m, ref.a.data(), sh.m) <= 1e-9 * scale);
        CHECK(max_abs_diff(B.slack_u.data() + size_t(e) * sh.k, ref.slack_u.data(), sh.k) <=
              1e-7 * (1.0 + amax(ref.slack_u)));
        CHECK(std::abs(B.lambda[e] - ref.lambda) <= 1e-9);
        CHECK(B.status[e] == ref.status);
        const bool out = (ref.status & kStatusBiasOutOfBounds) != 0;
        if (mod.bounds == BoundRule::CorrectionFirst) {
          // Always inside the box; when b was outside, a is b scaled as a whole.
          for (int j = 0; j < sh.m; ++j) CHECK(std::abs(B.a[size_t(e) * sh.m + j]) <= 1.0 + 1e-12);
          if (out) {
            const Eigen::VectorXd b = ref.b.head(sh.m);
            const Eigen::VectorXd a = Eigen::Map<const Eigen::VectorXd>(B.a.data() + size_t(e) * sh.m, sh.m);
            CHECK(amax(a - b / amax(b)) <= 1e-9 * scale);
            ++scaled;
          }
        } else if (out) {
          // The old rule hands the env b itself.
          CHECK(amax(ref.a - ref.b.head(sh.m)) == 0.0);
        }
      }
    }
  }
  CHECK(scaled > 20);
}

TEST_CASE("projector: the default factory and JSON carry the bound rule", "[projector]") {
  ProjectorModel mod = default_projector_model(3, 2, 4, 0);
  CHECK(mod.bounds == BoundRule::CorrectionFirst);
  nlohmann::json j = mod;
  CHECK(j.at("bounds") == "correction_first");
  j["bounds"] = "tangent_scale";
  CHECK(j.get<ProjectorModel>().bounds == BoundRule::TangentScale);
  j.erase("bounds");
  CHECK(j.get<ProjectorModel>().bounds == BoundRule::CorrectionFirst);
  j["bounds"] = "clip";
  CHECK_THROWS_WITH(j.get<ProjectorModel>(), Catch::Contains("unknown bound rule 'clip'"));
}
