// PushEnv, the test task of the Lagrangian learners (tests/test_sac_lag.cpp,
// tests/test_ppo_lag.cpp).
#pragma once
#include <algorithm>
#include <cmath>
#include <vector>

#include "atacom/env.hpp"

namespace atacom::testing {

// A bandit-like task whose only violation is avoidable: the reward of a step
// is its action a in [-1, 1] (more is better), its cost 1 when a > 0.5. The
// unconstrained optimum (a = 1) costs every step; a = 0.5 earns half of it
// at no cost. The observation is the time left; 50 steps per episode.
class PushEnv final : public BatchEnv {
 public:
  explicit PushEnv(int N) {
    spec_.name = "push";
    spec_.obs_dim = 1;
    spec_.act_dim = 1;
    spec_.obs_low = {0.0f};
    spec_.obs_high = {1.0f};
    spec_.dt = 0.1;
    spec_.horizon = kHorizon;
    spec_.gamma = 0.99;
    spec_.info_names = {"push"};
    spec_.info_reduce = {InfoReduce::Mean};
    buffers_.resize(spec_, N);
    t_.assign(size_t(N), 0);
    ret_.assign(size_t(N), 0.0);
  }
  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t) override { reset(nullptr); }
  void reset(const uint8_t* mask) override {
    for (int i = 0; i < num_envs(); ++i)
      if (!mask || mask[i]) {
        t_[size_t(i)] = 0;
        ret_[size_t(i)] = 0;
        buffers_.obs[size_t(i)] = buffers_.final_obs[size_t(i)] = 1.0f;
      }
  }
  void step(const double* a) override {
    EnvBuffers& b = buffers_;
    for (int i = 0; i < num_envs(); ++i) {
      const size_t s = size_t(i);
      const double x = std::isfinite(a[i]) ? std::clamp(a[i], -1.0, 1.0) : 0.0;
      b.reward[s] = float(x);
      b.cost[s] = x > 0.5 ? 1.0f : 0.0f;
      b.cost_continuous[s] = float(std::max(0.0, x - 0.5));
      b.info[s] = float(x);
      ret_[s] += x;
      ++t_[s];
      b.terminated[s] = 0;
      b.truncated[s] = t_[s] >= kHorizon;
      b.final_obs[s] = float(kHorizon - t_[s]) / kHorizon;
      if (b.truncated[s]) {
        b.episode_return[s] = ret_[s];
        b.episode_length[s] = t_[s];
        t_[s] = 0;
        ret_[s] = 0;
        b.obs[s] = 1.0f;
      } else {
        b.obs[s] = b.final_obs[s];
      }
    }
  }
  void save_state(std::ostream&) const override {}
  void load_state(std::istream&) override {}

 private:
  static constexpr int kHorizon = 50;
  EnvSpec spec_;
  std::vector<int> t_;
  std::vector<double> ret_;
};

}  // namespace atacom::testing
