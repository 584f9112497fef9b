// The hand-coded policies every env has: random and zero. (The env
// families' attractors live with their envs; make_attractor_policy looks
// them up in the registry, envs/registry.cpp.)
#include <algorithm>
#include <stdexcept>

#include "atacom/policy.hpp"

namespace atacom {

namespace {

class RandomPolicy final : public Policy {
 public:
  RandomPolicy(int obs_dim, int act_dim) : obs_dim_(obs_dim), act_dim_(act_dim) {}
  int obs_dim() const override { return obs_dim_; }
  int act_dim() const override { return act_dim_; }
  std::string kind() const override { return "random"; }
  void act(const float*, int N, bool, Rng* rngs, double* actions) override {
    if (rngs == nullptr) throw std::invalid_argument("random policy: needs per-env streams");
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < act_dim_; ++j) actions[size_t(i) * act_dim_ + j] = rngs[i].uniform(-1.0, 1.0);
  }

 private:
  int obs_dim_, act_dim_;
};

class ZeroPolicy final : public Policy {
 public:
  ZeroPolicy(int obs_dim, int act_dim) : obs_dim_(obs_dim), act_dim_(act_dim) {}
  int obs_dim() const override { return obs_dim_; }
  int act_dim() const override { return act_dim_; }
  std::string kind() const override { return "zero"; }
  void act(const float*, int N, bool, Rng*, double* actions) override {
    std::fill(actions, actions + size_t(N) * act_dim_, 0.0);
  }

 private:
  int obs_dim_, act_dim_;
};

}  // namespace

std::unique_ptr<Policy> make_random_policy(int obs_dim, int act_dim) {
  return std::make_unique<RandomPolicy>(obs_dim, act_dim);
}
std::unique_ptr<Policy> make_zero_policy(int obs_dim, int act_dim) {
  return std::make_unique<ZeroPolicy>(obs_dim, act_dim);
}

}  // namespace atacom
