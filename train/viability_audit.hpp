// `atacom viability`: the rollout of `atacom rollout --safety atacom`, step
// for step the same bits, that stops at every violating env-step (a row
// above its tolerance) and writes down why: the rows, their values before
// and after, the first-order prediction of the applied action, the
// correction b and the tangential part of the projector, which bound of the
// velocity box limited the tangential scale, the previous steps, and the
// exact answer to "did an action in the box exist that kept every row
// within its tolerance at first order" (a small QP, kernels/safelayer_qp).
// docs/projector.md ("Bounds") explains the classes.
#pragma once
#include <cstdint>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"
#include "train/rollout.hpp"

namespace atacom {

struct ViabilityAuditConfig {
  RolloutConfig rollout;                 // env, policy (random | zero | la), steps, envs, seed, env_config
  std::optional<BoundRule> bounds;       // unset: the env's projector model's rule
  std::string csv;                       // one line per violating row and step; empty: none
  long max_records = 100000;             // CSV lines at most (the counts go on)
};

// The exact one-step test of a first-order layer: is there an action a in
// [-1, 1]^m with c_i + dt (J_G,i a + F_i) <= bound_i on every row i? Solved
// as the SafeLayer QP (closest such action to a_pref, which must be inside
// the box); writes it to a when it exists. JG is (k x m) row-major.
bool first_order_keep_exists(int m, int k, const double* JG, const double* c, const double* F, const double* bound,
                             double dt, const double* a_pref, double* a);

// Returns the rollout's counts ("steps", "episodes", "violations",
// "max_constraint", ...) and "classes": violating env-steps by class
// (docs/projector.md): "chain" (the row already violated before the step),
// "not_viable" (no action in the box keeps every row within tolerance at
// first order), "bias_out" (the correction alone left the box and was
// clipped), "tangent" (the applied action's first-order prediction crosses
// the tolerance), "nonlinear" (the first-order prediction stays within
// tolerance, the reached state does not). Envs with drift or a moving
// part also get "max_drift_rate" (the largest rate F_i = J_q,i f + J_x,i
// xdot at which the uncontrolled motion closes a row) and
// "drift_over_escape_steps" (env-steps where some row closes faster than
// |J_G,i|_1 + s_i / dt: |J_G,i|_1 is the fastest retreat of that row inside
// the box, s_i = max(-c_i, 0) its room; no action keeps such a row at first
// order). Collisions are counted as run_rollout does ("collisions", or
// "<column>s" for every *collision info column). Throws std::invalid_argument for
// an env without constraints or a policy other than random, zero or la.
nlohmann::json run_viability_audit(const ViabilityAuditConfig& config);

}  // namespace atacom
