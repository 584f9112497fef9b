// Pendulum: Gymnasium's Pendulum-v1, batched.
//
// theta'' = 3 g / (2 l) sin(theta) + 3 / (m l^2) u, semi-implicit Euler with
// dt; thetadot clipped to +-max_speed; u = max_torque * action. Reward
// -(angle_normalize(theta)^2 + 0.1 thetadot^2 + 0.001 u^2) of the state before
// the step; obs [cos theta, sin theta, thetadot]; start theta ~ U(-pi, pi),
// thetadot ~ U(-1, 1); truncated after `horizon` steps, never terminated.
#pragma once
#include <cstdint>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "atacom/env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/rng.hpp"

namespace atacom {

struct PendulumModel {
  double g = 10.0;
  double m = 1.0;
  double l = 1.0;
  double dt = 0.05;
  double max_speed = 8.0;
  double max_torque = 2.0;
  int horizon = 200;
};
// The one default factory: Pendulum-v1's constants.
PendulumModel default_pendulum_model();
void to_json(nlohmann::json& j, const PendulumModel& p);
void from_json(const nlohmann::json& j, PendulumModel& p);  // unknown keys and bad values rejected

// ((x + pi) mod 2 pi) - pi with a floor modulo, as Gymnasium's angle_normalize.
double angle_normalize(double x);

// Per-env state, structure of arrays; written by reset and step. Its field
// list (the snapshot's PSTA section) is in pendulum.cpp.
struct PendulumBatch {
  std::vector<double> theta;      // (N) angle, 0 = upright; not wrapped
  std::vector<double> theta_dot;  // (N) angular velocity
  std::vector<int32_t> t;         // (N) steps into the current episode
  std::vector<double> ret;        // (N) return of the current episode so far
  std::vector<Rng> rng;           // (N) per-env streams keyed (seed, env id)
};

class PendulumEnv final : public BatchEnv {
 public:
  // info columns: "abs_theta" (|theta| after the step, reduced Last) and
  // "nonfinite_action" (1 when the action had NaN/Inf, treated as 0; Sum).
  PendulumEnv(const PendulumModel& model, int num_envs);

  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override;
  void load_state(std::istream& in) override;

  const PendulumModel& model() const { return model_; }
  double theta(int i) const { return st_.theta[size_t(i)]; }
  double theta_dot(int i) const { return st_.theta_dot[size_t(i)]; }

 private:
  void reset_one(int i);
  void write_obs(int i, float* obs) const;
  PendulumModel model_;
  EnvSpec spec_;
  PendulumBatch st_;
};

EnvEntry pendulum_env_entry();

}  // namespace atacom
