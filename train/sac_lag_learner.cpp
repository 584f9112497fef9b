#include "train/sac_lag_learner.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagSacLag = 0x4741534c;  // "LSAG"
const double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

SacLagLearner::SacLagLearner(const LearnerContext& ctx, const SacConfig& sac, const LagrangianConfig& lag)
    : N_(ctx.num_envs), sac_(ctx, sac, true), lag_(lag), episode_cost_(size_t(ctx.num_envs), 0.0) {
  sac_.set_cost_weight(lag_.value());
}

void SacLagLearner::observe(const float* obs, const double* actions, const EnvBuffers& b) {
  // Episodes of the untrained actor (before SAC's warm-up ends) say nothing
  // about the policy the multiplier weighs: they do not move it.
  const bool actor_learns = sac_.replay_size() > sac_.config().warmup;
  for (int i = 0; i < N_; ++i) {
    episode_cost_[size_t(i)] += b.cost[size_t(i)];
    if (!b.done(i)) continue;
    if (actor_learns) lag_.update(episode_cost_[size_t(i)]);
    window_cost_ += episode_cost_[size_t(i)];
    ++window_episodes_;
    episode_cost_[size_t(i)] = 0.0;
  }
  sac_.set_cost_weight(lag_.value());
  sac_.observe(obs, actions, b);
}

std::vector<std::string> SacLagLearner::progress_columns() const {
  std::vector<std::string> c = sac_.progress_columns();
  c.insert(c.end(), {"lagrange_multiplier", "train_episode_cost"});
  return c;
}

std::vector<double> SacLagLearner::progress_values() {
  std::vector<double> v = sac_.progress_values();
  v.push_back(lag_.value());
  v.push_back(window_episodes_ ? window_cost_ / double(window_episodes_) : kNaN);
  window_cost_ = 0;
  window_episodes_ = 0;
  return v;
}

nlohmann::json SacLagLearner::summary() const {
  nlohmann::json s = sac_.summary();
  s["cost_limit"] = lag_.config().cost_limit;
  s["lagrange_multiplier"] = lag_.value();
  return s;
}

nlohmann::json SacLagLearner::manifest() const {
  nlohmann::json m = sac_.manifest();
  m["lagrange_multiplier"] = lag_.value();
  return m;
}

void SacLagLearner::save(std::ostream& out) const {
  bin::write_tag(out, kTagSacLag);
  lag_.save(out);
  bin::write_vec(out, episode_cost_);
  bin::write_pod(out, window_cost_);
  bin::write_pod(out, window_episodes_);
  sac_.save(out);
}

void SacLagLearner::load(std::istream& in, int64_t env_steps) {
  bin::expect_tag(in, kTagSacLag, "sac-lag learner");
  LagrangeMultiplier lag(lag_.config());
  lag.load(in);
  std::vector<double> ep;
  bin::read_vec(in, ep, "sac_lag.episode_cost", int64_t(N_));
  const double wc = bin::read_pod<double>(in, "sac_lag.window_cost");
  const int64_t we = bin::read_pod<int64_t>(in, "sac_lag.window_episodes");
  auto bad = [](const std::string& what) { throw std::runtime_error("SAC-Lag learner state: " + what); };
  const double steps_per_env = double(env_steps) / double(N_);
  for (double c : ep)
    if (!(c >= 0 && c <= steps_per_env)) bad("a running episode cost outside [0, env steps per env]");
  if (lag.updates() > env_steps) bad("more multiplier updates than env steps");
  if (!(wc >= 0 && std::isfinite(wc)) || we < 0 || we > lag.updates()) bad("progress window out of range");
  sac_.load(in, env_steps);
  lag_ = lag;
  episode_cost_ = ep;
  window_cost_ = wc;
  window_episodes_ = we;
  sac_.set_cost_weight(lag_.value());
}

uint64_t SacLagLearner::state_hash() const {
  // SAC's own hash (networks with the cost critics, moments, temperature,
  // RNG) chained with the multiplier and the running episode costs.
  std::ostringstream s;
  bin::write_pod(s, sac_.state_hash());
  lag_.save(s);
  bin::write_vec(s, episode_cost_);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

std::unique_ptr<Learner> make_sac_lag_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  if (!ctx.sections || !ctx.sections->contains("lagrangian"))
    throw std::invalid_argument("sac-lag needs the resolved \"lagrangian\" section");
  return std::make_unique<SacLagLearner>(ctx, resolved.get<SacConfig>(), ctx.sections->at("lagrangian").get<LagrangianConfig>());
}

}  // namespace atacom
