// Proximal Policy Optimization (Schulman et al. 2017), clipped surrogate.
//
// Networks: a Gaussian actor (an Mlp: obs -> mean, plus log-std outputs when
// the log-std is state-dependent, else one learned log-std per action) and a
// separate value Mlp (obs -> 1), each with its own Adam. One update, over a
// full rollout of T steps x N envs (train/ppo_rollout.hpp):
//   1. values of every stored observation, of the truncated rows' true last
//      observations and of s_T, with the critic that acted (unchanged since);
//      GAE(lambda) advantages and returns;
//   2. `epochs` passes over a fresh permutation of the N*T rows, cut into
//      minibatches of about `minibatch_size`; per minibatch:
//        ratio = exp(log pi(u|s) - log pi_old(u|s)),
//        L_pi = -mean(min(ratio A, clip(ratio, 1 -+ clip_range) A)) - entropy_coef H,
//        L_V = 0.5 mean(max((V - R)^2, (V_old + clip(V - V_old, -+c) - R)^2))
//      (the second term only with value_clip_range), A normalised per
//      minibatch when normalize_advantages; each network's gradient clipped
//      to max_grad_norm, then one Adam step each (one "update" each).
//      With target_kl, the update stops before the first minibatch whose
//      approximate KL (mean((ratio - 1) - log ratio)) exceeds it.
// Actions: u ~ N(mean, std^2) is the policy's sample; the env gets clip(u,
// -1, 1) (the env contract's box, which ATACOM reads as alpha unchanged);
// the rollout stores u, and log pi is the Gaussian density of u (the clip is
// part of the environment). The deterministic action is clip(mean).
//
// With a cost critic (PPO-Lagrangian, train/lagrangian_learner.hpp): a
// second value network V_c (the critic's shape, its own Adam, lr_critic,
// max_grad_norm) on the rollout's 0/1 step costs, cost GAE(lambda) with the
// same gamma, lambda and episode cuts as the reward's, the clipped value
// loss on the cost returns in every minibatch, and the actor's advantage
//   A = (A_r - w A_c) / (1 + w)
// with w the multiplier (update()'s cost_weight), before the per-minibatch
// normalisation. Without one, nothing of it exists and the bits are plain PPO's.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "atacom/rng.hpp"
#include "train/adam.hpp"
#include "train/autodiff.hpp"
#include "train/mlp.hpp"
#include "train/ppo_rollout.hpp"

namespace atacom {

enum class LogStdMode : uint8_t { StateIndependent = 0, StateDependent = 1 };
enum class LrSchedule : uint8_t { Constant = 0, Linear = 1 };

struct PpoConfig {
  MlpConfig actor;                       // actor trunk
  MlpConfig critic;                      // value network
  int rollout_steps = 16;                // T: batch steps per rollout (N*T samples per update)
  int epochs = 10;                       // passes over the rollout per update
  int minibatch_size = 512;              // samples per gradient step (the rollout is cut into round(N*T / this))
  double gamma = 0.99;
  double gae_lambda = 0.95;
  double clip_range = 0.2;               // of the probability ratio
  std::optional<double> value_clip_range;  // nullopt: unclipped value loss
  double entropy_coef = 0.0;
  double lr_actor = 1e-3;
  double lr_critic = 1e-3;
  LrSchedule lr_schedule = LrSchedule::Constant;
  int64_t lr_decay_steps = 10'000'000;   // linear: the rates fall to 0 at this many env steps
  std::optional<double> target_kl;       // nullopt: no early stop
  bool normalize_advantages = true;
  bool obs_norm = true;                  // running mean/std normalisation (train/running_obs_norm.hpp)
  LogStdMode log_std = LogStdMode::StateIndependent;
  double init_log_std = -0.5;
  double log_std_min = -5.0;             // the log-std is clamped to [min, max] in both modes
  double log_std_max = 2.0;
  double max_grad_norm = 0.5;            // per network (actor with its log-std, critic); 0: off
  double reward_scale = 1.0;             // rewards are stored multiplied by this
  double init_output_scale = 0.01;       // the actor's output layer starts this much smaller
  AdamConfig adam;
};
// The one default factory (64-64 ReLU networks, T 16, 10 epochs, minibatches
// of 512, gamma 0.99, lambda 0.95, clip 0.2, lr 1e-3, state-independent
// log-std -0.5, gradient norm 0.5, running observation normalisation): the
// table run's first tuning pass (docs/training.md, "PPO"), meant for about
// 128 envs (train.num_envs).
PpoConfig default_ppo_config();
void to_json(nlohmann::json& j, const PpoConfig& c);
void from_json(const nlohmann::json& j, PpoConfig& c);  // unknown keys and bad values rejected

// Learning rate factor at `env_steps` under the config's schedule.
double ppo_lr_factor(const PpoConfig& c, int64_t env_steps);
// Minibatches per epoch of a rollout of S samples: S / minibatch_size
// rounded to the nearest integer, at least 1 (Ppo::update cuts the rollout
// into that many nearly equal parts).
inline int64_t ppo_minibatches(int64_t S, int minibatch_size) {
  const int64_t k = (S + minibatch_size / 2) / minibatch_size;
  return k > 0 ? k : 1;
}

// What the actor's act writes besides the actions (the learner's rollout).
struct PpoSample {
  float* u = nullptr;     // (N x A) pre-clip sample
  float* logp = nullptr;  // (N) its log-density
};

// Actions (N x A) for normalised obs (N x D): clip(mean) when deterministic,
// else clip(u), u = mean + exp(log_std) * n, n from rngs[i] for row i;
// `sample` (optional, stochastic only) receives u and log pi(u). `log_std`
// is the state-independent parameter (A), or nullptr when the actor outputs
// it. PpoPolicy and the learner act through this one function.
void ppo_actor_act(Mlp<float>& actor, const float* log_std, double log_std_min, double log_std_max,
                   Tape<float>& tape, const float* obs, int N, bool deterministic, Rng* rngs, double* actions,
                   const PpoSample* sample);

// One minibatch's losses recorded on a tape (float in training, double in
// the finite-difference tests), parameter gradients in GradMode::Set.
// Actor: L_pi - entropy_coef H over B rows of obs (B x D), pre-clip samples
// u (B x A), log pi_old (B) and advantages (B, used as given); log_std is the
// state-independent parameter (A) with its gradient buffer, or nullptr
// (state-dependent: the actor's second A outputs).
template <class T>
struct PpoActorLoss {
  typename Tape<T>::Id loss, policy_loss, log_std_sum, logp;  // log_std_sum: mean over rows of sum_j log-std
};
template <class T>
PpoActorLoss<T> record_ppo_actor_loss(Tape<T>& t, Mlp<T>& actor, T* log_std, T* log_std_grad, int act_dim,
                                      const PpoConfig& c, const T* obs, const T* u, const T* logp_old, const T* adv,
                                      int B);
// Critic: 0.5 mean((V - R)^2), or of the larger of it and the clipped
// term with value_clip_range (v_old: the values at the update's start).
template <class T>
typename Tape<T>::Id record_ppo_value_loss(Tape<T>& t, Mlp<T>& critic, const PpoConfig& c, const T* obs,
                                           const T* ret, const T* v_old, int B);

struct PpoStats {
  double policy_loss = 0, value_loss = 0, entropy = 0, approx_kl = 0, clip_fraction = 0;
  double explained_variance = 0;
  double cost_value_loss = 0;  // with a cost critic: its loss, averaged like value_loss
  int minibatch_steps = 0;  // gradient steps taken (epochs run x minibatches, fewer after a KL stop)
  int minibatches = 0;      // per epoch
};

class Ppo {
 public:
  Ppo(int obs_dim, int act_dim, const PpoConfig& cfg, uint64_t seed, bool cost_critic = false);
  ~Ppo();
  Ppo(const Ppo&) = delete;
  Ppo& operator=(const Ppo&) = delete;

  // The update of a full rollout (steps == T) at the given learning rates.
  // Writes the rollout's value/advantage arrays. Throws std::runtime_error
  // on a non-finite loss (before any step of that minibatch). cost_weight:
  // the multiplier w >= 0 (a cost critic only; the rollout must hold costs).
  PpoStats update(PpoRollout& r, double lr_actor, double lr_critic, double cost_weight = 0.0);

  // V(obs) for `rows` normalised observations, in fixed chunks.
  void values(const float* obs, int64_t rows, float* out);
  // The per-minibatch losses as the update takes them (gradients written to
  // the networks' grads(), nothing stepped): the finite-difference tests'
  // entry. adv is used as given (normalise before, if wanted).
  PpoStats losses(const float* obs, const float* u, const float* logp_old, const float* adv, const float* ret,
                  const float* v_old, int B);

  const PpoConfig& config() const { return cfg_; }
  int obs_dim() const { return obs_dim_; }
  int act_dim() const { return act_dim_; }
  Mlp<float>& actor() { return actor_; }
  const Mlp<float>& actor() const { return actor_; }
  Mlp<float>& critic() { return critic_; }
  const Mlp<float>& critic() const { return critic_; }
  bool has_cost_critic() const { return cost_ != nullptr; }
  const Mlp<float>& cost_critic() const;  // throws without one
  // (A) state-independent log-std parameter (unused when state-dependent)
  AlignedVector<float>& log_std() { return log_std_; }
  const AlignedVector<float>& log_std() const { return log_std_; }
  AlignedVector<float>& log_std_grad() { return log_std_grad_; }
  const float* log_std_param() const {
    return cfg_.log_std == LogStdMode::StateIndependent ? log_std_.data() : nullptr;
  }

  uint64_t state_hash() const;
  void save(std::ostream& out) const;
  void load(std::istream& in);  // throws on shape mismatch, truncation, non-finite values

  size_t allocations() const {
    return actor_tape_.allocations() + critic_tape_.allocations() + value_tape_.allocations();
  }
  double gemm_flops() const { return actor_tape_.gemm_flops() + critic_tape_.gemm_flops() + value_tape_.gemm_flops(); }

 private:
  void gather(const PpoRollout& r, const int32_t* idx, int B);
  void values_of(Mlp<float>& net, const float* obs, int64_t rows, float* out);
  double cost_loss(int B);  // records and back-propagates the cost critic's minibatch loss
  void step(double lr_actor, double lr_critic);

  PpoConfig cfg_;
  int obs_dim_, act_dim_;
  Mlp<float> actor_, critic_;
  AlignedVector<float> log_std_, log_std_grad_;  // (A)
  Adam<float> actor_opt_, log_std_opt_, critic_opt_;
  Rng rng_;  // minibatch permutations
  Tape<float> actor_tape_, critic_tape_, value_tape_;
  std::vector<int32_t> perm_;  // (T*N) row order of the current epoch
  // One minibatch, gathered (B rows at most max minibatch):
  AlignedVector<float> mb_obs_, mb_u_, mb_logp_, mb_adv_, mb_ret_, mb_v_;
  struct CostCritic;                  // the cost value network, its Adam, its tape and minibatch targets
  std::unique_ptr<CostCritic> cost_;  // null without
};

}  // namespace atacom
