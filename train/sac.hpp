// Soft Actor-Critic (Haarnoja et al. 2018) with automatic temperature.
//
// Networks: twin Q critics as one 2-member ensemble Mlp over concat(obs, a)
// with a Polyak-averaged target copy; a tanh-squashed Gaussian actor, one Mlp
// with 2 * act_dim outputs (mean, log-std clamped to [log_std_min,
// log_std_max]). One update:
//   1. actor and temperature (once the replay holds more than `warmup`):
//      L_pi = mean(alpha log pi(a~|s) - min_i Q_i(s, a~)),
//      L_alpha = -log_alpha * mean(log pi + target_entropy)
//   2. critics: y = r + gamma (1 - terminated) (min_i Q'_i(s', a') - alpha log pi(a'|s')),
//      L_Q = sum_i mean((Q_i(s, a) - y)^2); truncation still bootstraps.
//   3. Adam steps; target critics: Polyak with tau.
// Both gradients are taken at the parameters before this update's steps (so
// the two phases run concurrently): a' and alpha in 2. come from the actor
// and temperature before step 1's change. MushroomRL's SAC (the paper's)
// steps the actor and alpha first and draws a' from the stepped actor.
// Actions are in [-1, 1]^act_dim (the env contract). Observations reaching the
// agent are already normalised by the trainer when obs_norm is on.
//
// With a cost critic (SAC-Lagrangian, train/lagrangian_learner.hpp): twin cost
// critics Q_c as one more 2-member ensemble with its own Polyak target and
// Adam moments (the reward critics' network shape, lr_critic and tau),
//   y_c = c + gamma (1 - terminated) max_i Q'_c,i(s', a')   (the same a'; no entropy term),
//   L_Qc = sum_i mean((Q_c,i(s, a) - y_c)^2),
// the pessimistic (largest) cost estimate, and the actor's loss weighs it
// with the multiplier lambda (update()'s cost_weight), normalised so that
// its scale does not grow with lambda:
//   L_pi = mean(alpha log pi - min_i Q_i + lambda max_i Q_c,i) / (1 + lambda).
// Without one, nothing of it exists and the bits are plain SAC's.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <vector>

#include <nlohmann/json_fwd.hpp>
#include <tbb/task_group.h>

#include "train/adam.hpp"
#include "train/autodiff.hpp"
#include "train/mlp.hpp"
#include "train/replay_buffer.hpp"
#include "atacom/rng.hpp"

namespace atacom {

struct SacConfig {
  MlpConfig actor;                        // actor trunk
  MlpConfig critic;                       // each twin critic
  int batch_size = 64;
  double gamma = 0.995;
  double tau = 1e-3;                      // Polyak rate of the target critics
  double lr_actor = 3e-4;
  double lr_critic = 3e-4;
  double lr_alpha = 1e-6;
  double init_alpha = 1.0;                // log_alpha starts at log(init_alpha)
  std::optional<double> target_entropy;   // nullopt: -act_dim
  double log_std_min = -20.0;
  double log_std_max = 2.0;
  int64_t replay_capacity = 200000;
  int64_t initial_replay = 5000;          // critics update once replay size > this
  int64_t warmup = 5000;                  // actor and alpha update once replay size > this
  double updates_per_step = 1.0;          // gradient updates per env transition (may be < 1 or > 1)
  bool obs_norm = true;                   // map obs bounds to [-1, 1] (clipped to +-10)
  double grad_clip = 0.0;                 // max L2 norm of each network's gradient; 0: off
  AdamConfig adam;
};
// The one default factory (SacConfig{} holds the same values): the paper's
// settings (reference section 5): 256-256 ReLU, batch 64, lr 3e-4, tau 1e-3,
// replay 200k, initial replay and warmup 5000, gamma 0.995, lr_alpha 1e-6,
// MinMax observation normalisation.
SacConfig default_sac_config();
void to_json(nlohmann::json& j, const SacConfig& c);
void from_json(const nlohmann::json& j, SacConfig& c);  // unknown keys and bad values rejected

// The actor's action for obs (N x obs_dim, already normalised): tanh(mean)
// when deterministic, else tanh(mean + std * n) with n from rngs[i] for row
// i. `actor` has 2 * act_dim outputs (mean, log-std clamped to
// [log_std_min, log_std_max]); `tape` is the caller's scratch. Sac::act and
// the SAC policy of a run directory both act through this one function.
void sac_actor_act(Mlp<float>& actor, Tape<float>& tape, double log_std_min, double log_std_max,
                   const float* obs, int N, bool deterministic, Rng* rngs, double* actions);

struct SacStats {
  double actor_loss = 0, critic_loss = 0, alpha_loss = 0, entropy = 0, q_mean = 0;
  double cost_critic_loss = 0, cost_q_mean = 0;  // with a cost critic
  bool actor_updated = false;
};

class Sac {
 public:
  Sac(int obs_dim, int act_dim, const SacConfig& cfg, uint64_t seed, bool cost_critic = false);
  ~Sac() noexcept;
  Sac(const Sac&) = delete;
  Sac& operator=(const Sac&) = delete;

  // Actions (N x act_dim) in [-1, 1] for obs (N x obs_dim). Stochastic
  // actions draw row i's noise from rngs[i] (per-env streams); deterministic
  // ones are tanh(mean). No allocation after the first call with this N.
  // Non-finite observations give non-finite actions, which every env treats
  // as 0 and counts (env contract).
  void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions);

  // One gradient update on a sampled batch (B == batch_size). The critics'
  // Adam step may still be running on a worker when this returns, so that
  // the caller's env step overlaps it; every member below that reads the
  // critics, their targets or their moments waits for it first, so callers
  // observe the stepped agent, bit for bit.
  // cost_weight: the multiplier lambda >= 0 of the cost critic's term in the
  // actor loss (ignored without a cost critic).
  SacStats update(const ReplayBatch& batch, bool update_actor, double cost_weight = 0.0);

  double alpha() const;
  double log_alpha() const { return log_alpha_; }
  double target_entropy() const { return target_entropy_; }
  const SacConfig& config() const { return cfg_; }
  int obs_dim() const { return obs_dim_; }
  int act_dim() const { return act_dim_; }
  Rng& rng() { return rng_; }

  Mlp<float>& actor() { return actor_; }
  Mlp<float>& critic() { finish_steps(); return critic_; }
  Mlp<float>& critic_target() { finish_steps(); return critic_target_; }
  const Mlp<float>& actor() const { return actor_; }
  const Mlp<float>& critic() const { finish_steps(); return critic_; }
  const Mlp<float>& critic_target() const { finish_steps(); return critic_target_; }
  bool has_cost_critic() const { return cost_ != nullptr; }
  const Mlp<float>& cost_critic() const;  // throws without one

  // FNV-1a hash over every learned value (networks, targets, Adam moments,
  // temperature, RNG, the cost critic): equal hashes mean bitwise equal agents.
  uint64_t state_hash() const;
  // Everything the agent learned or drew, for checkpoints.
  void save(std::ostream& out) const;
  void load(std::istream& in);  // throws on shape mismatch or truncation

  // Memory requests of the update and act tapes (constant after warm-up).
  size_t allocations() const { return tape_.allocations() + actor_tape_.allocations() + act_tape_.allocations(); }
  double gemm_flops() const { return tape_.gemm_flops() + actor_tape_.gemm_flops() + act_tape_.gemm_flops(); }

 private:
  // Policy head on the tape: returns (action, log_prob) ids for obs id.
  struct PolicyOut { Tape<float>::Id action, logp; };
  PolicyOut policy(Tape<float>& tape, Tape<float>::Id obs, const float* noise, bool param_grads);
  void step_actor();
  void step_critic();  // critics' Adam step and the targets' Polyak update
  void finish_steps() const;  // waits for a deferred step_critic

  SacConfig cfg_;
  int obs_dim_, act_dim_;
  double target_entropy_;
  Mlp<float> actor_, critic_, critic_target_;
  Adam<float> actor_opt_, critic_opt_;
  Adam<double> alpha_opt_;
  double log_alpha_ = 0.0;
  Rng rng_;  // update noise
  Tape<float> tape_, actor_tape_, act_tape_;  // critic phase, actor phase, act()
  std::vector<float> noise_pi_;    // (B x act_dim) reparameterisation noise for the actor loss
  std::vector<float> noise_next_;  // (B x act_dim) noise for a' ~ pi(s')
  std::vector<float> y_;           // (B) critic targets
  // The cost critics (null without): written by the critic phase (grads) and step_critic.
  struct CostCritic {
    Mlp<float> critic, target;
    Adam<float> opt;
    std::vector<float> y;  // (B) targets
    CostCritic(int in, const SacConfig& cfg);
  };
  std::unique_ptr<CostCritic> cost_;
  // The deferred step_critic of the last update, if any. It writes only the
  // critics, their targets and critic_opt_ (and the cost critics').
  mutable tbb::task_group steps_;
  // Whether steps_ holds a task: wait() on an empty group still resets its
  // context, and the critic accessors call finish_steps() often.
  mutable bool steps_pending_ = false;
};

}  // namespace atacom
