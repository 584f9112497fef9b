// SAC behind the learner and policy contracts.
//
// SacPolicy: the tanh-Gaussian actor with the learner's observation
// normalisation (ObsNorm): raw observations in, actions in [-1, 1] out.
// SacLearner: owns the config section "sac" (every SacConfig key), the
// agent (train/sac.hpp), the replay buffer and its sampling stream, the
// update budget (updates_per_step per transition) and the loss windows that
// become progress.csv's alpha, actor_loss, critic_loss, alpha_loss, entropy
// and q_mean columns. The adversary (train/adversary.hpp) is a SacLearner
// that stores its own reward instead of the env's; SAC-Lag
// (train/lagrangian_learner.hpp) one with a cost critic (two more columns,
// cost_critic_loss and cost_q_mean) and the multiplier set before each step.
#pragma once
#include <memory>
#include <vector>

#include "atacom/learner.hpp"
#include "train/obs_norm.hpp"
#include "train/replay_buffer.hpp"
#include "train/sac.hpp"

namespace atacom {

class SacPolicy final : public Policy {
 public:
  // Acting with the learner's actor (training) ...
  SacPolicy(Mlp<float>& actor, const ObsNorm& norm, double log_std_min, double log_std_max);
  // ... or with its own, parameters set by load() (run directories).
  SacPolicy(const EnvSpec& spec, const SacConfig& config);

  int obs_dim() const override { return actor_->in(); }
  int act_dim() const override { return actor_->out() / 2; }
  std::string kind() const override { return "sac"; }
  void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) override;
  // Actor parameters, log-std bounds and the normalisation.
  void save(std::ostream& out) const override;
  void load(std::istream& in) override;

 private:
  std::unique_ptr<Mlp<float>> own_actor_;
  Mlp<float>* actor_;
  ObsNorm own_norm_;
  const ObsNorm* norm_;
  double log_std_min_, log_std_max_;
  Tape<float> tape_;
  std::vector<float> nobs_;  // (N x obs_dim) normalised observations
};

class SacLearner : public Learner {
 public:
  SacLearner(const LearnerContext& ctx, const SacConfig& config, bool cost_critic = false);
  SacLearner(const SacLearner&) = delete;  // the policy points into this object
  SacLearner& operator=(const SacLearner&) = delete;

  std::string name() const override { return "sac"; }
  Policy& policy() override { return policy_; }
  void observe(const float* obs, const double* actions, const EnvBuffers& after) override;
  // The same with a reward of the caller's (N), stored instead of after.reward.
  void observe_rewarded(const float* obs, const double* actions, const EnvBuffers& after, const float* reward);
  int64_t updates() const override { return updates_; }
  std::vector<std::string> progress_columns() const override;
  std::vector<double> progress_values() override;
  nlohmann::json summary() const override;
  nlohmann::json manifest() const override;
  void save(std::ostream& out) const override;
  void load(std::istream& in, int64_t env_steps) override;
  uint64_t state_hash() const override { return sac_.state_hash(); }  // networks, moments, temperature, RNG

  const Sac& agent() const { return sac_; }
  int64_t replay_size() const { return replay_.size(); }
  // The multiplier of the cost critic's term in the actor loss (cost critic only).
  void set_cost_weight(double w) { cost_weight_ = w; }
  const SacConfig& config() const { return cfg_; }

 private:
  SacConfig cfg_;
  int N_, D_, A_;
  Sac sac_;
  ObsNorm norm_;
  SacPolicy policy_;
  ReplayBuffer replay_;
  ReplayBatch batch_;
  Rng replay_rng_;
  std::vector<float> obs_n_;   // (N x D) normalised obs the actions were chosen for
  std::vector<float> next_n_;  // (N x D) normalised final_obs of the step
  // update budget and loss windows (checkpointed)
  double budget_ = 0;
  int64_t updates_ = 0, n_critic_ = 0, n_actor_ = 0;
  double critic_loss_ = 0, actor_loss_ = 0, alpha_loss_ = 0, entropy_ = 0, q_mean_ = 0;
  double cost_critic_loss_ = 0, cost_q_mean_ = 0;  // with a cost critic (checkpointed after the others)
  double cost_weight_ = 0;  // set by the owner before each observe (not state)
};

// Learner registry hooks (train/learner_registry.cpp).
nlohmann::json sac_default_config_json();
nlohmann::json sac_resolve_config(const nlohmann::json& section);
std::unique_ptr<Learner> make_sac_learner(const LearnerContext& ctx, const nlohmann::json& resolved);
std::unique_ptr<Policy> make_sac_policy(const EnvSpec& spec, const nlohmann::json& resolved);

}  // namespace atacom
