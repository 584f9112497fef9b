#include "train/ppo_learner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/json_number.hpp"
#include "src/core/limits.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagPpoPolicy = 0x50504f50;   // "PPOP"
constexpr uint32_t kTagPpoLearner = 0x50504f4c;  // "PPOL"
}  // namespace

// ---------------------------------------------------------------- policy
PpoPolicy::PpoPolicy(Ppo& agent, const ObsNorm& norm)
    : actor_(&agent.actor()),
      log_std_(agent.log_std_param()),
      norm_(&norm),
      act_dim_(agent.act_dim()),
      dependent_(agent.config().log_std == LogStdMode::StateDependent),
      log_std_min_(agent.config().log_std_min),
      log_std_max_(agent.config().log_std_max),
      records_(true) {}

PpoPolicy::PpoPolicy(const EnvSpec& spec, const PpoConfig& c)
    : own_actor_(std::make_unique<Mlp<float>>(spec.obs_dim, c.log_std == LogStdMode::StateDependent ? 2 * spec.act_dim
                                                                                                     : spec.act_dim,
                                              c.actor, 1)),
      actor_(own_actor_.get()),
      own_log_std_(size_t(spec.act_dim), float(c.init_log_std)),
      log_std_(c.log_std == LogStdMode::StateDependent ? nullptr : own_log_std_.data()),
      norm_(&own_norm_),
      act_dim_(spec.act_dim),
      dependent_(c.log_std == LogStdMode::StateDependent),
      log_std_min_(c.log_std_min),
      log_std_max_(c.log_std_max),
      records_(false) {
  RunningObsNorm identity;
  identity.init(spec.obs_dim, c.obs_norm);
  own_norm_ = identity.map();
}

void PpoPolicy::act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) {
  if (!deterministic && rngs == nullptr)
    throw std::invalid_argument("PPO policy: sampled actions need per-env streams");
  const size_t D = size_t(obs_dim()), A = size_t(act_dim_);
  if (nobs_.size() < size_t(N) * D) nobs_.resize(size_t(N) * D);
  norm_->apply(obs, nobs_.data(), N);
  PpoSample rec;
  const bool record = records_ && !deterministic;
  if (record) {
    if (sample_u_.size() < size_t(N) * A) sample_u_.resize(size_t(N) * A), sample_logp_.resize(size_t(N));
    rec = {sample_u_.data(), sample_logp_.data()};
    sampled_n_ = N;
  }
  ppo_actor_act(*actor_, log_std_, log_std_min_, log_std_max_, tape_, nobs_.data(), N, deterministic, rngs, actions,
                record ? &rec : nullptr);
}

void PpoPolicy::save(std::ostream& out) const {
  bin::write_tag(out, kTagPpoPolicy);
  bin::write_pod<int32_t>(out, obs_dim());
  bin::write_pod<int32_t>(out, act_dim_);
  bin::write_pod<uint8_t>(out, dependent_ ? 1 : 0);
  bin::write_pod<double>(out, log_std_min_);
  bin::write_pod<double>(out, log_std_max_);
  norm_->save(out);
  bin::write_vec(out, actor_->params());
  // The state-independent log-std (A); none when the actor outputs it.
  const AlignedVector<float> ls =
      log_std_ ? AlignedVector<float>(log_std_, log_std_ + act_dim_) : AlignedVector<float>();
  bin::write_vec(out, ls);
}

void PpoPolicy::load(std::istream& in) {
  if (!own_actor_) throw std::logic_error("PpoPolicy::load on a learner's policy");
  bin::expect_tag(in, kTagPpoPolicy, "ppo policy");
  const auto od = bin::read_pod<int32_t>(in, "ppo_policy.obs_dim");
  const auto ad = bin::read_pod<int32_t>(in, "ppo_policy.act_dim");
  if (od != obs_dim() || ad != act_dim_)
    throw std::runtime_error("PPO policy is for obs/act dims " + std::to_string(od) + "/" + std::to_string(ad) +
                             ", the env has " + std::to_string(obs_dim()) + "/" + std::to_string(act_dim_));
  const auto dep = bin::read_pod<uint8_t>(in, "ppo_policy.log_std_mode");
  if ((dep != 0) != dependent_) throw std::runtime_error("PPO policy: its log-std mode differs from the run's config");
  const double lo = bin::read_pod<double>(in, "ppo_policy.log_std_min");
  const double hi = bin::read_pod<double>(in, "ppo_policy.log_std_max");
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
    throw std::runtime_error("PPO policy has invalid log-std bounds");
  own_norm_.load(in);
  bin::read_vec(in, own_actor_->params(), "ppo_policy.actor", int64_t(own_actor_->params().size()));
  bin::read_vec(in, own_log_std_, "ppo_policy.log_std", dependent_ ? 0 : act_dim_);
  for (const auto* v : {&own_actor_->params(), &own_log_std_})
    for (float w : *v)
      if (!std::isfinite(w)) throw std::runtime_error("PPO policy holds a non-finite parameter");
  log_std_min_ = lo;
  log_std_max_ = hi;
  log_std_ = dependent_ ? nullptr : own_log_std_.data();
}

// ---------------------------------------------------------------- learner
PpoLearner::PpoLearner(const LearnerContext& ctx, const PpoConfig& c, bool cost_critic)
    : cfg_(c),
      N_(ctx.num_envs),
      D_(ctx.spec->obs_dim),
      A_(ctx.spec->act_dim),
      agent_(D_, A_, c, ctx.seed, cost_critic),
      policy_(agent_, norm_.map()),
      cost_(cost_critic) {
  const double rows = double(c.rollout_steps) * double(N_);
  limits::require_memory(rows * (2.0 * D_ + A_ + 10.0) * 4.0 + double(c.minibatch_size) * (D_ + A_ + 4.0) * 4.0,
                         "ppo.rollout_steps = " + std::to_string(c.rollout_steps) + " x train.num_envs = " +
                             std::to_string(N_) + " (the PPO rollout)");
  if (rows > double(std::numeric_limits<int32_t>::max()))
    throw std::invalid_argument("config: ppo.rollout_steps x train.num_envs must be below 2^31 rows");
  norm_.init(D_, c.obs_norm);
  if (ctx.initial) {  // the first observations acted on
    norm_.merge(ctx.initial->obs.data(), N_);
    norm_base_ = norm_.count();
  }
  roll_.resize(c.rollout_steps, N_, D_, A_, cost_critic);
}

double PpoLearner::learning_rate() const { return cfg_.lr_actor * ppo_lr_factor(cfg_, env_steps_); }

void PpoLearner::observe(const float* obs, const double* actions, const EnvBuffers& b) {
  const size_t N = size_t(N_), D = size_t(D_), A = size_t(A_);
  // The actions must be those of the policy's last sampled call.
  bool same = policy_.sampled_rows() == N_;
  for (size_t k = 0; same && k < N * A; ++k) {
    const double u = double(policy_.sampled_u()[k]);
    same = actions[k] == std::min(std::max(u, -1.0), 1.0) || (std::isnan(u) && std::isnan(actions[k]));
  }
  if (!same)
    throw std::logic_error("PPO learner: observe() got actions that its policy did not sample in the last call "
                           "(act with deterministic = false on the training batch, then step, then observe)");
  const size_t base = size_t(roll_.steps) * N;
  norm_.map().apply(obs, roll_.obs.data() + base * D, N_);  // the statistics the policy acted with
  std::copy_n(policy_.sampled_u(), N * A, roll_.sample.data() + base * A);
  std::copy_n(policy_.sampled_logp(), N, roll_.logp.data() + base);
  const float scale = float(cfg_.reward_scale);
  for (size_t i = 0; i < N; ++i) {
    const size_t k = base + i;
    roll_.reward[k] = b.reward[i] * scale;
    if (cost_) roll_.cost[k] = b.cost[i];
    roll_.terminated[k] = b.terminated[i] ? 1 : 0;
    roll_.truncated[k] = (b.truncated[i] && !b.terminated[i]) ? 1 : 0;
    roll_.final_row[k] = -1;
    if (roll_.truncated[k]) {
      const int32_t f = roll_.finals++;
      roll_.final_row[k] = f;
      norm_.map().apply(b.final_obs.data() + i * D, roll_.final_obs.data() + size_t(f) * D, 1);
    }
  }
  norm_.merge(b.obs.data(), N_);  // the next observations, before the policy acts on them
  ++roll_.steps;
  env_steps_ += N_;
  if (roll_.steps < roll_.T) return;
  norm_.map().apply(b.obs.data(), roll_.last_obs.data(), N_);
  const double f = ppo_lr_factor(cfg_, env_steps_);
  const PpoStats st = agent_.update(roll_, cfg_.lr_actor * f, cfg_.lr_critic * f, cost_weight_);
  roll_.steps = 0;
  roll_.finals = 0;
  ++rollouts_;
  updates_ += st.minibatch_steps;
  ++n_window_;
  const double epochs = double(st.minibatch_steps) / double(st.minibatches);
  const double v[7] = {st.policy_loss, st.value_loss, st.entropy, st.approx_kl, st.clip_fraction,
                       st.explained_variance, epochs};
  for (int j = 0; j < 7; ++j)
    if (std::isfinite(v[j])) sums_[j] += v[j];  // a KL stop before any step leaves the losses NaN
  if (cost_ && std::isfinite(st.cost_value_loss)) cost_sum_ += st.cost_value_loss;
}

std::vector<std::string> PpoLearner::progress_columns() const {
  std::vector<std::string> c = {"policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction",
                                "explained_variance", "learning_rate", "epochs"};
  if (cost_) c.push_back("cost_value_loss");
  return c;
}

std::vector<double> PpoLearner::progress_values() {
  const double n = double(n_window_);
  auto mean = [&](int j) { return n_window_ ? sums_[j] / n : kNaN; };
  std::vector<double> v = {mean(0), mean(1), mean(2), mean(3), mean(4), mean(5), learning_rate(), mean(6)};
  if (cost_) v.push_back(n_window_ ? cost_sum_ / n : kNaN);
  cost_sum_ = 0;
  n_window_ = 0;
  std::fill(std::begin(sums_), std::end(sums_), 0.0);
  return v;
}

nlohmann::json PpoLearner::summary() const {
  double std_mean = kNaN;
  if (const float* ls = agent_.log_std_param()) {
    std_mean = 0;
    for (int j = 0; j < A_; ++j)
      std_mean += std::exp(std::min(std::max(double(ls[j]), cfg_.log_std_min), cfg_.log_std_max));
    std_mean /= A_;
  }
  return {{"learning_rate", jnum(learning_rate())}, {"action_std", jnum(std_mean)}, {"rollouts", rollouts_}};
}

nlohmann::json PpoLearner::manifest() const {
  return {{"rollouts", rollouts_}, {"rollout_step", roll_.steps}, {"learning_rate", jnum(learning_rate())}};
}

void PpoLearner::save(std::ostream& out) const {
  bin::write_tag(out, kTagPpoLearner);
  bin::write_pod(out, env_steps_);
  bin::write_pod(out, updates_);
  bin::write_pod(out, rollouts_);
  bin::write_pod(out, n_window_);
  for (double x : sums_) bin::write_pod(out, x);
  agent_.save(out);
  norm_.save(out);
  roll_.save(out);
  if (cost_) bin::write_pod(out, cost_sum_);
}

void PpoLearner::load(std::istream& in, int64_t env_steps) {
  bin::expect_tag(in, kTagPpoLearner, "ppo learner");
  const auto steps = bin::read_pod<int64_t>(in, "ppo.env_steps");
  const auto updates = bin::read_pod<int64_t>(in, "ppo.updates");
  const auto rollouts = bin::read_pod<int64_t>(in, "ppo.rollouts");
  const auto window = bin::read_pod<int64_t>(in, "ppo.window");
  double sums[7];
  for (double& x : sums) x = bin::read_pod<double>(in, "ppo.loss_sums");
  auto bad = [](const std::string& what) { throw std::runtime_error("PPO learner state: " + what); };
  if (steps != env_steps)
    bad("it observed " + std::to_string(steps) + " transitions, the run's counters say " + std::to_string(env_steps));
  const int64_t batch_steps = env_steps / N_, T = cfg_.rollout_steps;
  if (rollouts != batch_steps / T)
    bad(std::to_string(rollouts) + " rollouts after " + std::to_string(batch_steps) + " batch steps of T = " +
        std::to_string(T));
  const int64_t most = rollouts * cfg_.epochs * ppo_minibatches(T * N_, cfg_.minibatch_size);
  if (updates < 0 || updates > most)
    bad(std::to_string(updates) + " gradient steps after " + std::to_string(rollouts) + " rollouts (at most " +
        std::to_string(most) + ")");
  if (window < 0 || window > rollouts) bad("loss window count out of range");
  for (double x : sums)
    if (!std::isfinite(x)) bad("non-finite loss sums");
  agent_.load(in);
  norm_.load(in);
  if (norm_.count() != (cfg_.obs_norm ? env_steps + norm_base_ : 0))
    bad("the normalisation statistics hold " + std::to_string(norm_.count()) + " observations after " +
        std::to_string(env_steps) + " env steps");
  roll_.load(in);
  const double cost_sum = cost_ ? bin::read_pod<double>(in, "ppo.cost_loss_sum") : 0.0;
  if (!std::isfinite(cost_sum)) bad("non-finite cost loss sum");
  if (roll_.steps != batch_steps % T)
    bad("the rollout holds " + std::to_string(roll_.steps) + " steps, the run is at step " +
        std::to_string(batch_steps % T) + " of its rollout");
  env_steps_ = steps;
  updates_ = updates;
  rollouts_ = rollouts;
  n_window_ = window;
  std::copy(std::begin(sums), std::end(sums), std::begin(sums_));
  cost_sum_ = cost_sum;
}

uint64_t PpoLearner::state_hash() const {
  std::ostringstream s;
  save(s);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

// ---------------------------------------------------------------- registry hooks
// PPO's generic defaults (64-64 ReLU, T 16, lr 1e-3, init log-std -0.5,
// ...). The per-env tuned keys (gamma 0.98, 5 epochs of 256 on the arm envs
// and nav) and --envs 128 are preset entries (configs/presets/*.json; the
// measurements behind them: docs/training.md, "PPO").
nlohmann::json ppo_default_config_json() { return default_ppo_config(); }

nlohmann::json ppo_resolve_config(const nlohmann::json& section) { return nlohmann::json(section.get<PpoConfig>()); }

std::unique_ptr<Learner> make_ppo_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  return std::make_unique<PpoLearner>(ctx, resolved.get<PpoConfig>());
}

std::unique_ptr<Policy> make_ppo_policy(const EnvSpec& spec, const nlohmann::json& resolved) {
  return std::make_unique<PpoPolicy>(spec, resolved.get<PpoConfig>());
}
}  // namespace atacom
