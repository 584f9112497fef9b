// ATACOM between any control-affine env and the agent.
//
// A ControlAffineEnv exposes, for its current state, the pieces of
// qdot = f(q) + G(q) a and of its constraints c(q, x) <= 0 (with J_q, J_x and
// xdot of the uncontrollable state). SafeEnv takes the agent's alpha in
// [-1, 1]^m, projects it with the batched ATACOM kernel, and steps the inner
// env with the safe control a. The same inner env runs unwrapped for plain RL.
#pragma once
#include <atomic>
#include <memory>
#include <vector>

#include "atacom/env.hpp"
#include "atacom/projector.hpp"

namespace atacom {

class ControlAffineEnv : public BatchEnv {
 public:
  // Dimensions and per-row slack settings; K_c defaults to 1/dt.
  virtual ProjectorModel projector_model() const = 0;
  // Write f, G, c, Jq, Jx, xdot of the current state of envs [begin, end)
  // into pb (sized for model and N). Must not allocate; may run concurrently
  // on disjoint ranges.
  virtual void constraint_model(ProjectorBatch& pb, int begin, int end) const = 0;
  // SafeLayer's per-row threshold C_i = -delta_i (k values; empty: 0 on every
  // row, the boundary c = 0 that ATACOM keeps, since the rows already carry
  // the env's margins; docs/safelayer.md).
  virtual std::vector<double> safelayer_threshold() const { return {}; }
};

class SafeEnv final : public BatchEnv {
 public:
  // info columns appended to the inner env's: "atacom_lambda", "atacom_status",
  // "max_constraint" (max_i c_i at the state the step reached).
  SafeEnv(std::unique_ptr<ControlAffineEnv> inner, const ProjectorModel& model);

  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  // actions = alpha (N x m) in [-1, 1].
  void step(const double* alpha) override;
  void save_state(std::ostream& out) const override { inner_->save_state(out); }
  void load_state(std::istream& in) override;
  // Profiling: the inner env's sections plus "projector" (constraint_model +
  // projection), all in thread-seconds.
  std::vector<std::string> profile_sections() const override;
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const ControlAffineEnv& inner() const { return *inner_; }
  ControlAffineEnv& inner() { return *inner_; }
  const ProjectorModel& model() const { return model_; }
  const ProjectorBatch& projection() const { return pb_; }  // last step's projector inputs and outputs

 private:
  void mirror_buffers();              // all rows of the inner env's buffers into ours
  void mirror_rows(int lo, int hi);   // rows [lo, hi)
  std::unique_ptr<ControlAffineEnv> inner_;
  ProjectorModel model_;
  ProjectorBatch pb_;
  EnvSpec spec_;
  int inner_info_ = 0;
  bool profiling_ = false;
  std::atomic<int64_t> projector_ns_{0};
};

}  // namespace atacom
