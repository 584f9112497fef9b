// SafeLayer between any control-affine env and the agent (Dalal et al. 2018,
// with the analytic rows the env gives ATACOM: the paper's fair comparison).
//
// SafeLayerEnv takes the agent's action in [-1, 1]^m, corrects it with the
// batched SafeLayer QP (include/atacom/safelayer.hpp) on the rows linearised
// over one control period, and steps the inner env with the result. The
// learner stores its own action: the layer is part of the env it acts in.
#pragma once
#include <memory>

#include <nlohmann/json.hpp>

#include "atacom/layered_env.hpp"
#include "atacom/safelayer.hpp"

namespace atacom {

class SafeLayerEnv final : public LayeredEnv {
 public:
  // info columns appended to the inner env's (per step):
  //   "safelayer_correction"  |a - a_pi|                         (episode mean)
  //   "safelayer_active"      rows active at the QP solution     (episode mean)
  //   "safelayer_iterations"  0 kept, 1 closed form, else QP     (episode mean)
  //   "safelayer_infeasible"  1 when no action satisfied every row (episode sum)
  //   "max_constraint"        max_i c_i at the state the step reached (episode max)
  // Profile section: "safelayer" (constraint model + QP).
  SafeLayerEnv(std::unique_ptr<ControlAffineEnv> inner, const SafeLayerModel& model);

  const SafeLayerModel& model() const { return model_; }
  const SafeLayerBatch& correction() const { return out_; }  // last step's outputs

 private:
  void take_actions(const double* actions) override;
  void correct_range(int lo, int hi) override;
  const double* controls() const override { return out_.a.data(); }
  void write_info(int64_t i, float* info) const override;
  SafeLayerModel model_;
  ProjectorModel pm_;  // shapes of the constraint-model batch
  ProjectorBatch pb_;
  SafeLayerBatch out_;
};

// The table's wrap for "safelayer" (no parameters: the rows linearised over
// the env's own control period, threshold 0 on every row, since the rows
// already carry the env's margins; docs/safelayer.md).
std::unique_ptr<BatchEnv> wrap_safelayer(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json& params);

}  // namespace atacom
