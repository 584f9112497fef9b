// Generalized ATACOM projector (paper: "Novel Formulation of ATACOM").
//
// System      qdot = f(q) + G(q) a,          q in R^n, a in R^m
// Constraints c(q, x) <= 0 in R^k,           J_q = dc/dq (k x n), J_x = dc/dx (k x p)
// Slack       s = max(-c, tol) per row,      A = diag(rate(s)) (see SlackType)
// Tangent     J_u = [J_q G, A],  F = J_q f + J_x xdot,  cbar = c + s
//             N = (I - J_u^T (J_u J_u^T)^-1 J_u) [I_m; 0]
// Control     [a; u_s] = N alpha - J_u^+ (F + K_c cbar),  a = N_a alpha + b
// Bounds      a = b + lambda N_a alpha, lambda the largest value in [0, 1]
//             keeping a inside [-1, 1]^m; b itself is never scaled.
//
// The batched kernel never forms the (k x k) system: with J_G = J_q G and
// W = A^-2, the push-through identity gives
//     N_a = (I_m + J_G^T W J_G)^-1,   b = -N_a J_G^T W (F + K_c cbar)
// (derivation in docs/projector.md), so the cost is linear in k.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace atacom {

// Slack parametrisation, as the rate a(s) of the slack column of J_u:
//   SoftCorner   a = min(exp(beta s), 1/tol) - 1   (paper's SoftCorner; default)
//   Exponential  a = beta s
//   Quadratic    a = sqrt(2 s)                     (original ATACOM, c + mu^2/2)
enum class SlackType : uint8_t { SoftCorner = 0, Exponential = 1, Quadratic = 2 };

// Projected: N Z as pinned in the paper (continuous, not orthonormal).
// Smooth:    the orthonormal null-space basis closest to Z (orthogonal
//            Procrustes, as the public reference code does).
enum class BasisType : uint8_t { Projected = 0, Smooth = 1 };

// How the batch stores G: a dense (n x m) matrix per env, or its diagonal
// (n == m), which velocity-controlled arms use.
enum class GForm : uint8_t { Dense = 0, Diagonal = 1 };

// How the control is kept inside [-1, 1]^m (docs/projector.md, "Bounds").
//   TangentScale     a = b + lambda t, lambda the largest in [0, 1] keeping the
//                    box; b is never scaled (outside the box: a = b, the env
//                    clips it per component).
//   CorrectionFirst  the same while b is inside the box; when it is not,
//                    lambda = 0 and b is scaled as a whole into the box
//                    (a = b / max_j |b_j|), so every row keeps its share of
//                    the correction instead of the per-component clip
//                    turning it.
enum class BoundRule : uint8_t { TangentScale = 0, CorrectionFirst = 1 };

// Per-env status bits written by the projector.
enum ProjectorStatus : uint32_t {
  kStatusOk = 0,
  kStatusBiasOutOfBounds = 1u << 0,   // b alone is outside [-1,1]^m: lambda = 0, a = b
  kStatusAlphaNonFinite = 1u << 1,    // NaN/Inf in alpha: replaced by 0 (pure correction)
  kStatusModelNonFinite = 1u << 2,    // NaN/Inf in f, G, c, J or xdot: a = 0 (stop)
  kStatusEqualityRankLoss = 1u << 3,  // equality rows dependent: solved in least squares
};

std::string slack_type_name(SlackType t);
SlackType parse_slack_type(const std::string& s);     // throws std::invalid_argument
std::string basis_type_name(BasisType t);
BasisType parse_basis_type(const std::string& s);     // throws std::invalid_argument
std::string bound_rule_name(BoundRule r);
BoundRule parse_bound_rule(const std::string& s);     // throws std::invalid_argument

// Static description shared by all envs of a batch.
struct ProjectorModel {
  int n = 0;  // state dimension of q
  int m = 0;  // control dimension
  int k = 0;  // constraint rows
  int p = 0;  // uncontrollable state dimension (0: no J_x / xdot)
  std::vector<SlackType> slack;     // (k)
  std::vector<double> beta;         // (k) slack shape, > 0
  std::vector<double> tol;          // (k) slack floor, > 0
  std::vector<uint8_t> equality;    // (k) 1: equality row, no slack column
  double K_c = 30.0;                // error-correction gain (1/dt at 30 Hz); 0 disables
  BasisType basis = BasisType::Projected;
  BoundRule bounds = BoundRule::TangentScale;  // the factory sets CorrectionFirst (issue 31)
  GForm g_form = GForm::Dense;
  bool has_drift = true;            // false: f == 0 and the f array is ignored

  int num_equality() const;
  // Throws std::invalid_argument naming the first inconsistency.
  void validate() const;
};

// The one default factory: SoftCorner, beta 3, tol 1e-6 on every row,
// no equality rows, K_c 30, projected basis, CorrectionFirst, dense G, drift.
ProjectorModel default_projector_model(int n, int m, int k, int p = 0);

void to_json(nlohmann::json& j, const ProjectorModel& model);
void from_json(const nlohmann::json& j, ProjectorModel& model);  // unknown keys rejected

// Structure-of-arrays batch of N envs. Inputs are written by the env's
// constraint kernel (or by the caller), outputs by project_batch().
struct ProjectorBatch {
  int N = 0;
  // inputs
  std::vector<double> f;       // (N x n)      drift f(q); unused when !has_drift
  std::vector<double> G;       // (N x n x m)  row-major, or (N x n) when g_form == Diagonal
  std::vector<double> c;       // (N x k)      constraint values
  std::vector<double> Jq;      // (N x k x n)  dc/dq, row-major
  std::vector<double> Jx;      // (N x k x p)  dc/dx, row-major
  std::vector<double> xdot;    // (N x p)      velocity of the uncontrollable state
  std::vector<double> alpha;   // (N x m)      policy action, clipped to [-1, 1] inside
  // outputs
  std::vector<double> a;       // (N x m)      safe control
  std::vector<double> slack_u; // (N x k)      slack control (the "sdot" rows); 0 on equality rows
  std::vector<double> s;       // (N x k)      slack value max(-c, tol); 0 on equality rows
  std::vector<double> lambda;  // (N)          tangential scale in [0, 1]
  std::vector<uint32_t> status;// (N)          ProjectorStatus bits
  // Optional diagnostics (filled only when requested, see ProjectOptions).
  std::vector<double> Na;      // (N x m x m)  action block of the basis

  ProjectorBatch() = default;
  ProjectorBatch(const ProjectorModel& model, int N);
  void resize(const ProjectorModel& model, int N);
};

struct ProjectOptions {
  bool store_basis = false;   // write Na (tests and the filter's diagnostics)
  bool store_slack = true;    // write s and slack_u; envs that only need a skip them
                              // (the kernel is memory-bound at large N: ~20% less traffic)
  bool parallel = true;       // TBB over blocks; false runs on the calling thread
};

// Project envs [begin, end) of the batch. No allocation after the first call
// on each thread. Thread-count independent: every env is computed alone.
void project_range(const ProjectorModel& model, ProjectorBatch& batch, int begin, int end,
                   const ProjectOptions& opt = {});
// Project all N envs, TBB-parallel over fixed blocks.
void project_batch(const ProjectorModel& model, ProjectorBatch& batch, const ProjectOptions& opt = {});

// Slack helpers, shared by the kernel, the reference and the tests.
double slack_value(double c, double tol);                             // max(-c, tol)
double slack_rate(SlackType type, double s, double beta, double tol); // a(s)

// Largest lambda in [0, 1] with b + lambda t inside [-1, 1]^m (sign-aware);
// 0 when b alone is outside (sets *bias_out when given).
double tangent_scale(const double* b, const double* t, int m, bool* bias_out = nullptr);

}  // namespace atacom
