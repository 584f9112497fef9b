// SafeLayer (Dalal et al. 2018) on the analytic constraint rows.
//
// Per env, every row is linearised over one control period,
//   c_i(s') ~ c_i + dt (F_i + (J_q G)_i a),   F = J_q f + J_x xdot,
// and the action is the exact solution of the small QP
//   min 1/2 |a - a_pi|^2   s.t.  g_i a <= h_i (every row),  -1 <= a_j <= 1,
// with g_i = dt (J_q G)_i, h_i = C_i - c_i - dt F_i, a_pi = clip(alpha, -1, 1)
// and C_i the per-row threshold. Solver ladder (docs/safelayer.md):
//   1. a_pi feasible: a = a_pi (0 iterations);
//   2. Dalal's closed form a = a_pi - lambda g_i on the row farthest away,
//      kept when it satisfies every row and the box (1 iteration);
//   3. otherwise the exact QP: for m <= 2 an enumeration of the candidate
//      active sets (2 iterations), else the least-distance QP (Lawson-Hanson
//      NNLS on the LDP dual), bounded by 3 (k + 2m) iterations;
//   4. infeasible (no action in the box satisfies every row): the action in
//      the box with the least squared row violation, status kSafeLayerInfeasible.
// The inputs are those the ATACOM projector gets (ProjectorBatch's f, G, c,
// J_q, J_x, xdot, alpha), so both layers read the same env model.
#pragma once
#include <cstdint>
#include <vector>

#include "atacom/projector.hpp"

namespace atacom {

enum SafeLayerStatus : uint32_t {
  kSafeLayerOk = 0,
  kSafeLayerInfeasible = 1u << 0,       // no action in the box satisfies every row: least-violation action
  kSafeLayerAlphaNonFinite = 1u << 1,   // NaN/Inf in alpha: replaced by 0
  kSafeLayerModelNonFinite = 1u << 2,   // NaN/Inf in f, G, c, J or xdot: a = 0
  kSafeLayerIterationLimit = 1u << 3,   // a solver hit its iteration bound (the result is still checked)
};

// Feasibility tolerance of a row, in the row's units (c): a row with
// g_i a - h_i <= kSafeLayerFeasTol counts as satisfied, and a row within it
// of equality as active.
constexpr double kSafeLayerFeasTol = 1e-9;
// A row whose |g_i| is below this cannot be moved by the action this step:
// it is dropped from the QP (and makes it infeasible when already violated).
constexpr double kSafeLayerRowEps = 1e-14;

struct SafeLayerModel {
  int n = 0, m = 0, k = 0, p = 0;  // as in ProjectorModel
  GForm g_form = GForm::Dense;
  bool has_drift = true;
  double dt = 1.0 / 30.0;          // linearisation period, s (> 0)
  std::vector<double> threshold;   // (k) C_i = -delta_i

  // Throws std::invalid_argument naming the first inconsistency.
  void validate() const;
};

// The SafeLayer model of an env whose ATACOM model is `pm` (same shapes, G
// form and drift), with period dt and thresholds (k values, or one for every
// row, or empty for 0).
SafeLayerModel safelayer_model(const ProjectorModel& pm, double dt, const std::vector<double>& threshold = {});

// Outputs per env; inputs come from a ProjectorBatch sized for the same shapes.
struct SafeLayerBatch {
  int N = 0;
  std::vector<double> a;            // (N x m) safe action
  std::vector<double> correction;   // (N) |a - a_pi|
  std::vector<int32_t> active;      // (N) rows active at the solution (|g_i a - h_i| <= tol)
  std::vector<int32_t> iterations;  // (N) 0 a_pi kept, 1 closed form, else 1 + QP iterations
  std::vector<uint32_t> status;     // (N) SafeLayerStatus bits
  std::vector<uint8_t> active_rows; // (N x k) 1 for an active row; filled only with store_active_rows

  SafeLayerBatch() = default;
  SafeLayerBatch(const SafeLayerModel& model, int N) { resize(model, N); }
  void resize(const SafeLayerModel& model, int N);
};

struct SafeLayerOptions {
  bool store_active_rows = false;
  bool parallel = true;  // TBB over fixed blocks; false: the calling thread
};

// Envs [begin, end). No allocation after the first call on each thread for
// a shape; every env is solved alone, so results do not depend on threads.
void safelayer_range(const SafeLayerModel& model, const ProjectorBatch& in, SafeLayerBatch& out, int begin, int end,
                     const SafeLayerOptions& opt = {});
void safelayer_batch(const SafeLayerModel& model, const ProjectorBatch& in, SafeLayerBatch& out,
                     const SafeLayerOptions& opt = {});

// One QP in its reduced form (tests, the filter): rows g (k x m, row-major),
// h (k), a_pi (m, inside the box). Writes a (m); when mult != nullptr, the
// KKT multipliers (k + 2m: rows, then a_j <= 1, then -a_j <= 1), zero in the
// infeasible case. Returns SafeLayerStatus bits; *iterations as in the batch.
uint32_t safelayer_solve(int m, int k, const double* g, const double* h, const double* a_pi, double* a,
                         int* iterations = nullptr, double* mult = nullptr);

}  // namespace atacom
