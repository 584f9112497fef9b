// SAC-Lagrangian (the constrained-MDP baseline of OmniSafe and Safety-
// Gymnasium): SAC with twin cost critics (train/sac.hpp) whose cost estimate
// enters the actor loss with the run's Lagrange multiplier
// (train/lagrangian.hpp), moved by every finished training episode's cost
// (EnvBuffers::cost summed over the episode) against the budget cost_limit.
// Config sections: "sac" (the SAC settings, as for `sac`) and "lagrangian".
// Per batch step, in this order: every episode that ended updates the
// multiplier (env index order; only once the replay holds more than SAC's
// warm-up, when the actor learns: the untrained actor's episodes do not
// count), then SAC stores the transitions and runs its updates with the new
// multiplier.
//
// progress.csv adds to SAC's columns cost_critic_loss, cost_q_mean,
// lagrange_multiplier (at the row) and train_episode_cost (the mean cost of
// the training episodes that ended since the previous row; NaN: none);
// summary.json adds cost_limit and lagrange_multiplier. The multiplier, its
// controller state, the running episode costs and the cost critics are in
// the checkpoint and the state hash (SAC's hash chained with the multiplier
// and the running episode costs).
#pragma once
#include <memory>
#include <vector>

#include "atacom/learner.hpp"
#include "train/lagrangian.hpp"
#include "train/sac_learner.hpp"

namespace atacom {

class SacLagLearner final : public Learner {
 public:
  SacLagLearner(const LearnerContext& ctx, const SacConfig& sac, const LagrangianConfig& lag);

  std::string name() const override { return "sac-lag"; }
  Policy& policy() override { return sac_.policy(); }
  void observe(const float* obs, const double* actions, const EnvBuffers& after) override;
  int64_t updates() const override { return sac_.updates(); }
  std::vector<std::string> progress_columns() const override;
  std::vector<double> progress_values() override;
  nlohmann::json summary() const override;
  nlohmann::json manifest() const override;
  void save(std::ostream& out) const override;
  void load(std::istream& in, int64_t env_steps) override;
  uint64_t state_hash() const override;

  const LagrangeMultiplier& multiplier() const { return lag_; }
  const SacLearner& sac() const { return sac_; }

 private:
  int N_;
  SacLearner sac_;
  LagrangeMultiplier lag_;
  std::vector<double> episode_cost_;  // (N) cost of each env's running episode
  double window_cost_ = 0;            // finished episodes' costs since the last progress row
  int64_t window_episodes_ = 0;
};

std::unique_ptr<Learner> make_sac_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved);

}  // namespace atacom
