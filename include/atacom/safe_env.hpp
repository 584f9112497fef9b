// ATACOM between any control-affine env and the agent.
//
// SafeEnv takes the agent's alpha in [-1, 1]^m, projects it with the batched
// ATACOM kernel, and steps the inner env (a ControlAffineEnv) with the safe
// control a. The same inner env runs unwrapped for plain RL.
#pragma once
#include <memory>

#include <nlohmann/json.hpp>

#include "atacom/control_affine_env.hpp"
#include "atacom/layered_env.hpp"
#include "atacom/projector.hpp"

namespace atacom {

class SafeEnv final : public LayeredEnv {
 public:
  // info columns appended to the inner env's: "atacom_lambda" (episode mean),
  // "atacom_bias_out" (steps whose bias left the action bounds or whose model
  // was non-finite, episode sum), "max_constraint" (max_i c_i at the state
  // the step reached, episode max). Profile section: "projector".
  SafeEnv(std::unique_ptr<ControlAffineEnv> inner, const ProjectorModel& model);

  const ProjectorModel& model() const { return model_; }
  const ProjectorBatch& projection() const { return pb_; }  // last step's projector inputs and outputs

 private:
  void take_actions(const double* alpha) override;
  void correct_range(int lo, int hi) override;
  const double* controls() const override { return pb_.a.data(); }
  void write_info(int64_t i, float* info) const override;
  ProjectorModel model_;
  ProjectorBatch pb_;
};

// The table's wrap for "atacom" (no parameters: the env's projector model).
std::unique_ptr<BatchEnv> wrap_atacom(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json& params);

}  // namespace atacom
