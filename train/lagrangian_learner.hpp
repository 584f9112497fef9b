// The Lagrangian learners (sac-lag, ppo-lag; the constrained-MDP baselines
// of OmniSafe and Safety-Gymnasium): a learner with a cost critic (SAC's
// twin cost critics, train/sac.hpp; PPO's cost value network and cost GAE,
// train/ppo.hpp) whose cost term is weighed by the run's Lagrange
// multiplier (train/lagrangian.hpp), moved by every finished training
// episode's cost (EnvBuffers::cost summed over the episode) against the
// budget cost_limit. One class for both: the wrapped learner only says how
// it takes the multiplier and whether its actor learns yet.
// Config sections: the wrapped learner's ("sac" or "ppo") and "lagrangian".
// Per batch step, in this order: every episode that ended updates the
// multiplier (env index order; only while the actor learns: SAC's
// untrained actor before its warm-up does not count, PPO's always does),
// then the wrapped learner observes the step with the new multiplier (SAC
// stores it and runs its updates, PPO stores it and updates at a full
// rollout).
//
// progress.csv adds to the wrapped learner's columns (SAC's cost_critic_loss
// and cost_q_mean, PPO's cost_value_loss) lagrange_multiplier (at the row)
// and train_episode_cost (the mean cost of the training episodes that ended
// since the previous row; NaN: none); summary.json adds cost_limit and
// lagrange_multiplier. The multiplier, its controller state, the running
// episode costs and the cost critics are in the checkpoint and the state
// hash (the wrapped learner's hash chained with the multiplier and the
// running episode costs).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "atacom/learner.hpp"
#include "train/lagrangian.hpp"

namespace atacom {

// How a wrapped learner takes the multiplier.
struct CostWeightHooks {
  std::function<void(double)> set_weight;  // the multiplier for its next update
  std::function<bool()> actor_learns;      // whether finished episodes move the multiplier now
};

class LagrangianLearner final : public Learner {
 public:
  // name: "sac-lag" or "ppo-lag"; tag: its checkpoint tag; hooks act on *inner.
  LagrangianLearner(const LearnerContext& ctx, std::string name, uint32_t tag, std::unique_ptr<Learner> inner,
                    CostWeightHooks hooks, const LagrangianConfig& lag);

  std::string name() const override { return name_; }
  Policy& policy() override { return inner_->policy(); }
  void observe(const float* obs, const double* actions, const EnvBuffers& after) override;
  int64_t updates() const override { return inner_->updates(); }
  std::vector<std::string> progress_columns() const override;
  std::vector<double> progress_values() override;
  nlohmann::json summary() const override;
  nlohmann::json manifest() const override;
  void save(std::ostream& out) const override;
  void load(std::istream& in, int64_t env_steps) override;
  uint64_t state_hash() const override;

  const LagrangeMultiplier& multiplier() const { return lag_; }
  const Learner& inner() const { return *inner_; }

 private:
  std::string name_;
  uint32_t tag_;
  int N_;
  std::unique_ptr<Learner> inner_;
  CostWeightHooks hooks_;
  LagrangeMultiplier lag_;
  std::vector<double> episode_cost_;  // (N) cost of each env's running episode
  double window_cost_ = 0;            // finished episodes' costs since the last progress row
  int64_t window_episodes_ = 0;
};

// The registry's factories (train/learner_registry.cpp): SAC with twin cost
// critics and PPO with a cost value network, each behind the multiplier.
std::unique_ptr<Learner> make_sac_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved);
std::unique_ptr<Learner> make_ppo_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved);

}  // namespace atacom
