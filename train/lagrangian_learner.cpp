#include "train/lagrangian_learner.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/json_number.hpp"
#include "train/ppo_learner.hpp"
#include "train/sac_learner.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagSacLag = 0x4741534c;  // "LSAG"
constexpr uint32_t kTagPpoLag = 0x4750504c;  // "LPPG"

LagrangianConfig lagrangian_section_of(const LearnerContext& ctx, const std::string& name) {
  if (!ctx.sections || !ctx.sections->contains("lagrangian"))
    throw std::invalid_argument(name + " needs the resolved \"lagrangian\" section");
  return ctx.sections->at("lagrangian").get<LagrangianConfig>();
}
}  // namespace

LagrangianLearner::LagrangianLearner(const LearnerContext& ctx, std::string name, uint32_t tag,
                                     std::unique_ptr<Learner> inner, CostWeightHooks hooks,
                                     const LagrangianConfig& lag)
    : name_(std::move(name)),
      tag_(tag),
      N_(ctx.num_envs),
      inner_(std::move(inner)),
      hooks_(std::move(hooks)),
      lag_(lag),
      episode_cost_(size_t(ctx.num_envs), 0.0) {
  hooks_.set_weight(lag_.value());
}

void LagrangianLearner::observe(const float* obs, const double* actions, const EnvBuffers& b) {
  // Episodes of an untrained actor (SAC before its warm-up ends) say nothing
  // about the policy the multiplier weighs: they do not move it.
  const bool learns = hooks_.actor_learns();
  for (int i = 0; i < N_; ++i) {
    episode_cost_[size_t(i)] += b.cost[size_t(i)];
    if (!b.done(i)) continue;
    if (learns) lag_.update(episode_cost_[size_t(i)]);
    window_cost_ += episode_cost_[size_t(i)];
    ++window_episodes_;
    episode_cost_[size_t(i)] = 0.0;
  }
  hooks_.set_weight(lag_.value());
  inner_->observe(obs, actions, b);
}

std::vector<std::string> LagrangianLearner::progress_columns() const {
  std::vector<std::string> c = inner_->progress_columns();
  c.insert(c.end(), {"lagrange_multiplier", "train_episode_cost"});
  return c;
}

std::vector<double> LagrangianLearner::progress_values() {
  std::vector<double> v = inner_->progress_values();
  v.push_back(lag_.value());
  v.push_back(window_episodes_ ? window_cost_ / double(window_episodes_) : kNaN);
  window_cost_ = 0;
  window_episodes_ = 0;
  return v;
}

nlohmann::json LagrangianLearner::summary() const {
  nlohmann::json s = inner_->summary();
  s["cost_limit"] = lag_.config().cost_limit;
  s["lagrange_multiplier"] = lag_.value();
  return s;
}

nlohmann::json LagrangianLearner::manifest() const {
  nlohmann::json m = inner_->manifest();
  m["lagrange_multiplier"] = lag_.value();
  return m;
}

void LagrangianLearner::save(std::ostream& out) const {
  bin::write_tag(out, tag_);
  lag_.save(out);
  bin::write_vec(out, episode_cost_);
  bin::write_pod(out, window_cost_);
  bin::write_pod(out, window_episodes_);
  inner_->save(out);
}

void LagrangianLearner::load(std::istream& in, int64_t env_steps) {
  bin::expect_tag(in, tag_, (name_ + " learner").c_str());
  LagrangeMultiplier lag(lag_.config());
  lag.load(in);
  std::vector<double> ep;
  bin::read_vec(in, ep, "lagrangian.episode_cost", int64_t(N_));
  const double wc = bin::read_pod<double>(in, "lagrangian.window_cost");
  const int64_t we = bin::read_pod<int64_t>(in, "lagrangian.window_episodes");
  auto bad = [&](const std::string& what) { throw std::runtime_error(name_ + " learner state: " + what); };
  const double steps_per_env = double(env_steps) / double(N_);
  for (double c : ep)
    if (!(c >= 0 && c <= steps_per_env)) bad("a running episode cost outside [0, env steps per env]");
  if (lag.updates() > env_steps) bad("more multiplier updates than env steps");
  if (!(wc >= 0 && std::isfinite(wc)) || we < 0 || we > env_steps) bad("progress window out of range");
  inner_->load(in, env_steps);
  lag_ = lag;
  episode_cost_ = ep;
  window_cost_ = wc;
  window_episodes_ = we;
  hooks_.set_weight(lag_.value());
}

uint64_t LagrangianLearner::state_hash() const {
  // The wrapped learner's own hash (networks with the cost critics, moments,
  // RNG, ...) chained with the multiplier and the running episode costs.
  std::ostringstream s;
  bin::write_pod(s, inner_->state_hash());
  lag_.save(s);
  bin::write_vec(s, episode_cost_);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

std::unique_ptr<Learner> make_sac_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  const LagrangianConfig lag = lagrangian_section_of(ctx, "sac-lag");
  auto sac = std::make_unique<SacLearner>(ctx, resolved.get<SacConfig>(), true);
  SacLearner* s = sac.get();
  CostWeightHooks hooks{[s](double w) { s->set_cost_weight(w); },
                        [s] { return s->replay_size() > s->config().warmup; }};
  return std::make_unique<LagrangianLearner>(ctx, "sac-lag", kTagSacLag, std::move(sac), std::move(hooks), lag);
}

std::unique_ptr<Learner> make_ppo_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  const LagrangianConfig lag = lagrangian_section_of(ctx, "ppo-lag");
  auto ppo = std::make_unique<PpoLearner>(ctx, resolved.get<PpoConfig>(), true);
  PpoLearner* p = ppo.get();
  CostWeightHooks hooks{[p](double w) { p->set_cost_weight(w); }, [] { return true; }};
  return std::make_unique<LagrangianLearner>(ctx, "ppo-lag", kTagPpoLag, std::move(ppo), std::move(hooks), lag);
}
}  // namespace atacom
