// SafeLayer between any control-affine env and the agent (Dalal et al. 2018,
// with the analytic rows the env gives ATACOM: the paper's fair comparison).
//
// SafeLayerEnv takes the agent's action in [-1, 1]^m, corrects it with the
// batched SafeLayer QP (include/atacom/safelayer.hpp) on the rows linearised
// over one control period, and steps the inner env with the result. The
// learner stores its own action: the layer is part of the env it acts in.
#pragma once
#include <atomic>
#include <memory>

#include "atacom/safe_env.hpp"
#include "atacom/safelayer.hpp"

namespace atacom {

class SafeLayerEnv final : public BatchEnv {
 public:
  // info columns appended to the inner env's (per step):
  //   "safelayer_correction"  |a - a_pi|                         (episode mean)
  //   "safelayer_active"      rows active at the QP solution     (episode mean)
  //   "safelayer_iterations"  0 kept, 1 closed form, else QP     (episode mean)
  //   "safelayer_infeasible"  1 when no action satisfied every row (episode sum)
  //   "max_constraint"        max_i c_i at the state the step reached (episode max)
  SafeLayerEnv(std::unique_ptr<ControlAffineEnv> inner, const SafeLayerModel& model);

  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override { inner_->save_state(out); }
  void load_state(std::istream& in) override;
  // The inner env's sections plus "safelayer" (constraint model + QP), thread-seconds.
  std::vector<std::string> profile_sections() const override;
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const ControlAffineEnv& inner() const { return *inner_; }
  ControlAffineEnv& inner() { return *inner_; }
  const SafeLayerModel& model() const { return model_; }
  const SafeLayerBatch& correction() const { return out_; }  // last step's outputs

 private:
  void mirror_rows(int lo, int hi);
  std::unique_ptr<ControlAffineEnv> inner_;
  SafeLayerModel model_;
  ProjectorModel pm_;  // shapes of the constraint-model batch
  ProjectorBatch pb_;
  SafeLayerBatch out_;
  EnvSpec spec_;
  int inner_info_ = 0;
  bool profiling_ = false;
  std::atomic<int64_t> layer_ns_{0};
};

}  // namespace atacom
