#include "train/sac_learner.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/json_number.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagSacPolicy = 0x53414350;   // "SACP"
constexpr uint32_t kTagSacLearner = 0x5341434c;  // "SACL"
constexpr uint64_t kReplayStream = uint64_t{3} << 32;  // replay sampling: stream (seed, kReplayStream)
}  // namespace

// ---------------------------------------------------------------- policy
SacPolicy::SacPolicy(Mlp<float>& actor, const ObsNorm& norm, double log_std_min, double log_std_max)
    : actor_(&actor), norm_(&norm), log_std_min_(log_std_min), log_std_max_(log_std_max) {}

SacPolicy::SacPolicy(const EnvSpec& spec, const SacConfig& c)
    : own_actor_(std::make_unique<Mlp<float>>(spec.obs_dim, 2 * spec.act_dim, c.actor, 1)),
      actor_(own_actor_.get()),
      norm_(&own_norm_),
      log_std_min_(c.log_std_min),
      log_std_max_(c.log_std_max) {
  own_norm_.init(spec, c.obs_norm);
}

void SacPolicy::act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) {
  if (!deterministic && rngs == nullptr) throw std::invalid_argument("SAC policy: sampled actions need per-env streams");
  nobs_.resize(size_t(N) * size_t(obs_dim()));
  norm_->apply(obs, nobs_.data(), N);
  sac_actor_act(*actor_, tape_, log_std_min_, log_std_max_, nobs_.data(), N, deterministic, rngs, actions);
}

void SacPolicy::save(std::ostream& out) const {
  bin::write_tag(out, kTagSacPolicy);
  bin::write_pod<int32_t>(out, obs_dim());
  bin::write_pod<int32_t>(out, act_dim());
  bin::write_pod<double>(out, log_std_min_);
  bin::write_pod<double>(out, log_std_max_);
  norm_->save(out);
  bin::write_vec(out, actor_->params());
}

void SacPolicy::load(std::istream& in) {
  if (!own_actor_) throw std::logic_error("SacPolicy::load on a learner's policy");
  bin::expect_tag(in, kTagSacPolicy, "sac policy");
  const auto od = bin::read_pod<int32_t>(in, "sac_policy.obs_dim");
  const auto ad = bin::read_pod<int32_t>(in, "sac_policy.act_dim");
  if (od != obs_dim() || ad != act_dim())
    throw std::runtime_error("SAC policy is for obs/act dims " + std::to_string(od) + "/" + std::to_string(ad) +
                             ", the env has " + std::to_string(obs_dim()) + "/" + std::to_string(act_dim()));
  const double lo = bin::read_pod<double>(in, "sac_policy.log_std_min");
  const double hi = bin::read_pod<double>(in, "sac_policy.log_std_max");
  if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
    throw std::runtime_error("SAC policy has invalid log-std bounds");
  own_norm_.load(in);
  bin::read_vec(in, own_actor_->params(), "sac_policy.actor", int64_t(own_actor_->params().size()));
  for (float w : own_actor_->params())
    if (!std::isfinite(w)) throw std::runtime_error("SAC policy holds a non-finite actor parameter");
  log_std_min_ = lo;
  log_std_max_ = hi;
}

// ---------------------------------------------------------------- learner
SacLearner::SacLearner(const LearnerContext& ctx, const SacConfig& c, bool cost_critic)
    : cfg_(c),
      N_(ctx.num_envs),
      D_(ctx.spec->obs_dim),
      A_(ctx.spec->act_dim),
      sac_(D_, A_, c, ctx.seed, cost_critic),
      policy_(sac_.actor(), norm_, c.log_std_min, c.log_std_max),
      replay_(c.replay_capacity, D_, A_) {
  if (c.replay_capacity < c.batch_size) throw std::invalid_argument("config: sac.replay_capacity must be >= sac.batch_size");
  norm_.init(*ctx.spec, c.obs_norm);
  batch_.resize(c.batch_size, D_, A_);
  replay_rng_.reseed(ctx.seed, kReplayStream);
  obs_n_.assign(size_t(N_) * D_, 0.0f);
  next_n_ = obs_n_;
}

void SacLearner::observe(const float* obs, const double* actions, const EnvBuffers& after) {
  observe_rewarded(obs, actions, after, after.reward.data());
}

void SacLearner::observe_rewarded(const float* obs, const double* actions, const EnvBuffers& b, const float* reward) {
  norm_.apply(obs, obs_n_.data(), N_);
  norm_.apply(b.final_obs.data(), next_n_.data(), N_);
  replay_.add(N_, obs_n_.data(), actions, reward, b.cost.data(), next_n_.data(), b.terminated.data(),
              b.truncated.data());
  budget_ += cfg_.updates_per_step * N_;
  while (budget_ >= 1.0) {
    budget_ -= 1.0;
    if (replay_.size() <= cfg_.initial_replay || replay_.size() < cfg_.batch_size) continue;
    replay_.sample(replay_rng_, batch_);
    const SacStats st = sac_.update(batch_, replay_.size() > cfg_.warmup, cost_weight_);
    ++updates_;
    ++n_critic_;
    critic_loss_ += st.critic_loss;
    q_mean_ += st.q_mean;
    cost_critic_loss_ += st.cost_critic_loss;
    cost_q_mean_ += st.cost_q_mean;
    if (st.actor_updated) {
      ++n_actor_;
      actor_loss_ += st.actor_loss;
      alpha_loss_ += st.alpha_loss;
      entropy_ += st.entropy;
    }
  }
}

std::vector<std::string> SacLearner::progress_columns() const {
  std::vector<std::string> c = {"alpha", "actor_loss", "critic_loss", "alpha_loss", "entropy", "q_mean"};
  if (sac_.has_cost_critic()) c.insert(c.end(), {"cost_critic_loss", "cost_q_mean"});
  return c;
}

std::vector<double> SacLearner::progress_values() {
  std::vector<double> v = {sac_.alpha(),
                           n_actor_ ? actor_loss_ / double(n_actor_) : kNaN,
                           n_critic_ ? critic_loss_ / double(n_critic_) : kNaN,
                           n_actor_ ? alpha_loss_ / double(n_actor_) : kNaN,
                           n_actor_ ? entropy_ / double(n_actor_) : kNaN,
                           n_critic_ ? q_mean_ / double(n_critic_) : kNaN};
  if (sac_.has_cost_critic())
    v.insert(v.end(), {n_critic_ ? cost_critic_loss_ / double(n_critic_) : kNaN,
                       n_critic_ ? cost_q_mean_ / double(n_critic_) : kNaN});
  n_critic_ = n_actor_ = 0;
  critic_loss_ = actor_loss_ = alpha_loss_ = entropy_ = q_mean_ = 0;
  cost_critic_loss_ = cost_q_mean_ = 0;
  return v;
}

nlohmann::json SacLearner::summary() const { return {{"alpha", jnum(sac_.alpha())}}; }

nlohmann::json SacLearner::manifest() const {
  return {{"replay_size", replay_.size()}, {"alpha", jnum(sac_.alpha())}};
}

void SacLearner::save(std::ostream& out) const {
  bin::write_tag(out, kTagSacLearner);
  bin::write_pod(out, budget_);
  bin::write_pod(out, updates_);
  bin::write_pod(out, n_critic_);
  bin::write_pod(out, n_actor_);
  for (double x : {critic_loss_, actor_loss_, alpha_loss_, entropy_, q_mean_}) bin::write_pod(out, x);
  if (sac_.has_cost_critic())  // plain SAC's layout has no such sums
    for (double x : {cost_critic_loss_, cost_q_mean_}) bin::write_pod(out, x);
  sac_.save(out);
  replay_.save(out);
  bin::write_rng(out, replay_rng_);
}

void SacLearner::load(std::istream& in, int64_t env_steps) {
  bin::expect_tag(in, kTagSacLearner, "sac learner");
  const auto budget = bin::read_pod<double>(in, "sac.budget");
  const auto updates = bin::read_pod<int64_t>(in, "sac.updates");
  const auto n_critic = bin::read_pod<int64_t>(in, "sac.n_critic");
  const auto n_actor = bin::read_pod<int64_t>(in, "sac.n_actor");
  double sums[7] = {0, 0, 0, 0, 0, 0, 0};
  for (int i = 0; i < (sac_.has_cost_critic() ? 7 : 5); ++i) sums[i] = bin::read_pod<double>(in, "sac.loss_sums");
  auto bad = [](const std::string& what) { throw std::runtime_error("SAC learner state: " + what); };
  if (!(budget >= 0.0 && budget < 1.0)) bad("update budget " + std::to_string(budget) + " not in [0, 1)");
  // Every transition adds updates_per_step to the budget; each update spends 1.
  const double most = double(env_steps) * cfg_.updates_per_step;
  if (updates < 0 || double(updates) > most + 1.0)
    bad(std::to_string(updates) + " updates after " + std::to_string(env_steps) + " env steps at updates_per_step " +
        std::to_string(cfg_.updates_per_step));
  if (n_critic < 0 || n_critic > updates || n_actor < 0 || n_actor > n_critic) bad("loss window counts out of range");
  for (double x : sums)
    if (!std::isfinite(x)) bad("non-finite loss sums");
  sac_.load(in);
  if (!std::isfinite(sac_.log_alpha())) bad("non-finite temperature");
  replay_.load(in);
  if (replay_.size() != std::min<int64_t>(env_steps, replay_.capacity()))
    bad("replay holds " + std::to_string(replay_.size()) + " transitions after " + std::to_string(env_steps) +
        " env steps (capacity " + std::to_string(replay_.capacity()) + ")");
  bin::read_rng(in, replay_rng_, "sac.replay_rng");
  budget_ = budget;
  updates_ = updates;
  n_critic_ = n_critic;
  n_actor_ = n_actor;
  critic_loss_ = sums[0];
  actor_loss_ = sums[1];
  alpha_loss_ = sums[2];
  entropy_ = sums[3];
  q_mean_ = sums[4];
  cost_critic_loss_ = sums[5];
  cost_q_mean_ = sums[6];
}

// ---------------------------------------------------------------- registry hooks
// The one default factory's values (per env and layer settings are presets: train/presets.hpp).
nlohmann::json sac_default_config_json() { return default_sac_config(); }

nlohmann::json sac_resolve_config(const nlohmann::json& section) { return nlohmann::json(section.get<SacConfig>()); }

std::unique_ptr<Learner> make_sac_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  return std::make_unique<SacLearner>(ctx, resolved.get<SacConfig>());
}

std::unique_ptr<Policy> make_sac_policy(const EnvSpec& spec, const nlohmann::json& resolved) {
  return std::make_unique<SacPolicy>(spec, resolved.get<SacConfig>());
}
}  // namespace atacom
