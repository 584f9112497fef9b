// What every safety layer between a ControlAffineEnv and the agent shares.
//
// A LayeredEnv takes the agent's action (N x m in [-1, 1]), lets the layer
// turn it into controls block by block (constraint model + correction, timed
// as one profile section), steps the inner env with them, and mirrors the
// inner buffers with the layer's info columns and "max_constraint" (max_i c_i
// at the state the step reached, episode max) appended. Seeding, resets and
// snapshots are the inner env's.
#pragma once
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "atacom/control_affine_env.hpp"

namespace atacom {

class LayeredEnv : public BatchEnv {
 public:
  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override { inner_->save_state(out); }
  void load_state(std::istream& in) override;
  // The inner env's sections plus the layer's, all in thread-seconds.
  std::vector<std::string> profile_sections() const override;
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  const ControlAffineEnv& inner() const { return *inner_; }
  ControlAffineEnv& inner() { return *inner_; }

 protected:
  struct InfoColumn {
    const char* name;
    InfoReduce reduce;
  };
  // Throws std::invalid_argument naming `layer` when inner is null.
  LayeredEnv(std::unique_ptr<ControlAffineEnv> inner, const char* layer, std::string section,
             const std::vector<InfoColumn>& columns);

  // The agent's actions (N x m) become the layer's input.
  virtual void take_actions(const double* actions) = 0;
  // Constraint model and correction of envs [lo, hi): runs concurrently on
  // disjoint ranges, must not allocate.
  virtual void correct_range(int lo, int hi) = 0;
  // The controls (N x m) the inner env steps with.
  virtual const double* controls() const = 0;
  // The layer's info columns of env i (in constructor order, max_constraint excluded).
  virtual void write_info(int64_t i, float* info) const = 0;

 private:
  void mirror_rows(int lo, int hi);
  std::unique_ptr<ControlAffineEnv> inner_;
  std::string section_;
  EnvSpec spec_;
  int inner_info_ = 0;
  bool profiling_ = false;
  std::atomic<int64_t> layer_ns_{0};
};

}  // namespace atacom
