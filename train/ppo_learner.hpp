// PPO behind the learner and policy contracts.
//
// PpoPolicy: the Gaussian actor with the learner's running observation
// normalisation: raw observations in, clip(u) in [-1, 1] out. The learner's
// own policy also keeps the pre-clip sample u and its log-density of its last
// sampled call, which observe() stores (the trainer acts, steps the env and
// observes in that order; observe checks that the actions it is handed are
// that call's).
// PpoLearner: owns the config section "ppo" (every PpoConfig key), the
// agent (train/ppo.hpp), the normalisation statistics, the rollout (a
// checkpoint inside a rollout holds its rows) and the loss windows that
// become progress.csv's policy_loss, value_loss, entropy, approx_kl,
// clip_fraction, explained_variance, learning_rate and epochs columns.
// updates() counts gradient steps (minibatches), not rollouts.
#pragma once
#include <memory>
#include <vector>

#include "atacom/learner.hpp"
#include "train/ppo.hpp"
#include "train/ppo_rollout.hpp"
#include "train/running_obs_norm.hpp"

namespace atacom {

class PpoPolicy final : public Policy {
 public:
  // Acting with the learner's actor and normalisation (training) ...
  PpoPolicy(Ppo& agent, const ObsNorm& norm);
  // ... or with its own, parameters set by load() (run directories).
  PpoPolicy(const EnvSpec& spec, const PpoConfig& config);

  int obs_dim() const override { return actor_->in(); }
  int act_dim() const override { return act_dim_; }
  std::string kind() const override { return "ppo"; }
  void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) override;
  // Actor parameters, the log-std (mode, bounds, parameter) and the normalisation map.
  void save(std::ostream& out) const override;
  void load(std::istream& in) override;

  // The last sampled call (learner's policy only): N, and per row u (A) and log pi(u).
  int sampled_rows() const { return sampled_n_; }
  const float* sampled_u() const { return sample_u_.data(); }
  const float* sampled_logp() const { return sample_logp_.data(); }

 private:
  std::unique_ptr<Mlp<float>> own_actor_;
  Mlp<float>* actor_;
  AlignedVector<float> own_log_std_;  // (A) state-independent log-std of a loaded policy
  const float* log_std_;              // (A) or nullptr (state-dependent)
  ObsNorm own_norm_;
  const ObsNorm* norm_;
  int act_dim_;
  bool dependent_;
  double log_std_min_, log_std_max_;
  bool records_;                      // the learner's policy keeps its samples
  Tape<float> tape_;
  std::vector<float> nobs_;           // (N x obs_dim) normalised observations
  std::vector<float> sample_u_, sample_logp_;  // (N x A), (N) of the last sampled call
  int sampled_n_ = 0;
};

class PpoLearner final : public Learner {
 public:
  // cost_critic: PPO-Lagrangian's (train/ppo.hpp): the rollout keeps the
  // step costs, the agent a cost critic; progress.csv adds cost_value_loss.
  PpoLearner(const LearnerContext& ctx, const PpoConfig& config, bool cost_critic = false);
  PpoLearner(const PpoLearner&) = delete;  // the policy points into this object
  PpoLearner& operator=(const PpoLearner&) = delete;

  std::string name() const override { return "ppo"; }
  Policy& policy() override { return policy_; }
  void observe(const float* obs, const double* actions, const EnvBuffers& after) override;
  int64_t updates() const override { return updates_; }
  std::vector<std::string> progress_columns() const override;
  std::vector<double> progress_values() override;
  nlohmann::json summary() const override;
  nlohmann::json manifest() const override;
  void save(std::ostream& out) const override;
  void load(std::istream& in, int64_t env_steps) override;
  uint64_t state_hash() const override;  // agent, statistics, rollout, counters, windows

  const Ppo& agent() const { return agent_; }
  Ppo& agent() { return agent_; }
  const PpoRollout& rollout() const { return roll_; }
  const RunningObsNorm& obs_norm() const { return norm_; }
  const PpoConfig& config() const { return cfg_; }
  double learning_rate() const;  // the actor's, at the current env step
  // The multiplier weighing the cost advantage in the next update (a cost critic only).
  void set_cost_weight(double w) { cost_weight_ = w; }

 private:
  PpoConfig cfg_;
  int N_, D_, A_;
  Ppo agent_;
  RunningObsNorm norm_;
  PpoPolicy policy_;
  PpoRollout roll_;
  int64_t env_steps_ = 0;   // transitions observed
  int64_t updates_ = 0;     // gradient steps
  int64_t rollouts_ = 0;    // PPO updates (full rollouts)
  int64_t norm_base_ = 0;   // observations in the statistics before the first step (the initial batch)
  // Loss window since the last progress row (checkpointed): rollouts and sums.
  int64_t n_window_ = 0;
  double sums_[7] = {};     // policy_loss, value_loss, entropy, approx_kl, clip_fraction, explained_variance, epochs
  bool cost_ = false;       // a cost critic (checkpointed after the rest: plain PPO's bytes unchanged)
  double cost_weight_ = 0;
  double cost_sum_ = 0;     // cost_value_loss over the window
};

// Learner registry hooks (train/learner_registry.cpp). The defaults are
// PPO's generic ones; the per-env tuned settings are preset entries
// (configs/presets/{paper,fast}.json, docs/training.md "PPO").
nlohmann::json ppo_default_config_json();
nlohmann::json ppo_resolve_config(const nlohmann::json& section);
std::unique_ptr<Learner> make_ppo_learner(const LearnerContext& ctx, const nlohmann::json& resolved);
std::unique_ptr<Policy> make_ppo_policy(const EnvSpec& spec, const nlohmann::json& resolved);

}  // namespace atacom
