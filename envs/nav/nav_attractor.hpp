// The paper's Linear Attractor (LA) for NavEnv (reference digest 6.2): drive
// towards the goal with v = k_v |e| and turn with omega = k_w * heading error,
// both clipped. It reads the 18-dim nav observation, so it runs unchanged on
// the plain env (LA) and as the alpha of the ATACOM-wrapped env (LA-ATACOM).
#pragma once
#include <memory>

#include <nlohmann/json_fwd.hpp>

#include "atacom/policy.hpp"

namespace atacom {

struct NavAttractorParams {
  double k_v = 1.0;      // v = clip(k_v |e|, -v_clip, v_clip), m/s
  double v_clip = 1.0;
  double k_w = 1.0;      // omega = clip(k_w * heading error, -w_clip, w_clip), rad/s
  double w_clip = 1.57;
  double v_max = 1.0;    // physical limits of the env's action box, used to
  double w_max = 1.0471975511965976;  // normalise the output to [-1, 1]
};

NavAttractorParams default_nav_attractor_params();
void to_json(nlohmann::json& j, const NavAttractorParams& p);
void from_json(const nlohmann::json& j, NavAttractorParams& p);  // strict

// obs: (N x obs_dim) nav observations (goal at columns 0-1, TIAGo x, y, cos,
// sin at 2-5); actions: (N x 2) normalised [v, omega] in [-1, 1].
void nav_linear_attractor(const NavAttractorParams& p, const float* obs, int obs_dim, int N, double* actions);

// The same behind the Policy contract (deterministic; `rngs` unused).
class NavAttractorPolicy final : public Policy {
 public:
  NavAttractorPolicy(const NavAttractorParams& params, int obs_dim) : p_(params), obs_dim_(obs_dim) {}
  int obs_dim() const override { return obs_dim_; }
  int act_dim() const override { return 2; }
  std::string kind() const override { return "attractor"; }
  void act(const float* obs, int N, bool, Rng*, double* actions) override {
    nav_linear_attractor(p_, obs, obs_dim_, N, actions);
  }

 private:
  NavAttractorParams p_;
  int obs_dim_;
};

// Registry hook (EnvEntry::make_attractor): the default gains with the
// config's TIAGo speed limits (tiago.v_max, tiago.w_max) as the action box.
std::unique_ptr<Policy> make_nav_attractor(const nlohmann::json& resolved_config);

}  // namespace atacom
