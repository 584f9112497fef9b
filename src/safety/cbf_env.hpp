// A CBF-QP safety layer (control barrier function, Ames et al. 2017) on the
// env's analytic rows: the action closest to the policy's under which no
// constraint value approaches its boundary faster than exponentially,
//   min 1/2 |a - a_pi|^2   s.t.  J_q (f + G a) + J_x xdot <= -gamma c  (every row),
//                                -1 <= a_j <= 1,
// a_pi = clip(alpha, -1, 1), gamma > 0 (1/s). Every row divided by gamma is
// SafeLayer's row with period dt = 1/gamma and threshold 0,
// c + dt (F + J_q G a) <= 0 with F = J_q f + J_x xdot, so the layer runs the
// SafeLayer kernel and QP solver (include/atacom/safelayer.hpp) on that
// model: same solver, other right-hand side. A uniform positive scale of the
// rows changes neither the QP's solution nor the least squared violation
// answer of an infeasible step (status kSafeLayerInfeasible). With gamma =
// 1/dt of the env (30 at 30 Hz) the layer is SafeLayer; a smaller gamma
// brakes earlier.
#pragma once
#include <memory>

#include <nlohmann/json.hpp>

#include "atacom/layered_env.hpp"
#include "atacom/safelayer.hpp"

namespace atacom {

// gamma's default on every env: a row may close a third of its distance to
// the boundary per control period of 1/30 s at most when gamma = 10, against
// all of it for SafeLayer's one-period linearisation (gamma = 30).
constexpr double kCbfDefaultGamma = 10.0;

// The SafeLayer model of the CBF rows for an env whose ATACOM model is `pm`.
// Throws std::invalid_argument unless gamma is finite and > 0.
SafeLayerModel cbf_model(const ProjectorModel& pm, double gamma);

class CbfEnv final : public LayeredEnv {
 public:
  // info columns appended to the inner env's (per step):
  //   "cbf_correction"  |a - a_pi|                         (episode mean)
  //   "cbf_active"      rows active at the QP solution     (episode mean)
  //   "cbf_iterations"  0 kept, 1 closed form, else QP     (episode mean)
  //   "cbf_infeasible"  1 when no action satisfied every row (episode sum)
  //   "max_constraint"  max_i c_i at the state the step reached (episode max)
  // Profile section: "cbf" (constraint model + QP).
  CbfEnv(std::unique_ptr<ControlAffineEnv> inner, double gamma);

  double gamma() const { return gamma_; }
  const SafeLayerModel& model() const { return model_; }
  const SafeLayerBatch& correction() const { return out_; }  // last step's outputs

 private:
  void take_actions(const double* actions) override;
  void correct_range(int lo, int hi) override;
  const double* controls() const override { return out_.a.data(); }
  void write_info(int64_t i, float* info) const override;
  double gamma_;
  SafeLayerModel model_;
  ProjectorModel pm_;  // shapes of the constraint-model batch
  ProjectorBatch pb_;
  SafeLayerBatch out_;
};

// The table's entry for "cbf": parameters {"gamma": kCbfDefaultGamma} on every env, and the wrap.
nlohmann::json cbf_default_params(const std::string& env);
std::unique_ptr<BatchEnv> wrap_cbf(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json& params);

}  // namespace atacom
