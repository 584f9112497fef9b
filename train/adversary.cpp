#include "train/adversary.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"
#include "src/core/json_number.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagAdversary = 0x41445652;  // "ADVR"
}  // namespace

AdversaryConfig default_adversary_config() {
  AdversaryConfig c;
  c.sac = default_sac_config();
  c.sac.actor.hidden = c.sac.critic.hidden = {64, 64};
  c.sac.lr_actor = c.sac.lr_critic = 1e-3;
  c.sac.lr_alpha = 3e-4;
  c.sac.initial_replay = 1000;
  c.sac.warmup = 1000;
  c.sac.replay_capacity = 100000;
  c.sac.gamma = 0.99;
  c.collision_bonus = 100.0;
  return c;
}

void to_json(nlohmann::json& j, const AdversaryConfig& c) {
  j = nlohmann::json{{"sac", c.sac},
                     {"collision_bonus", c.collision_bonus},
                     {"scale_floor", c.scale_floor},
                     {"reward_cap", c.reward_cap},
                     {"worst_states", c.worst_states}};
}

void from_json(const nlohmann::json& j, AdversaryConfig& c) {
  ConfigReader r(j, "adversary");
  AdversaryConfig a = default_adversary_config();
  if (const auto* s = r.sub("sac")) {
    // The adversary's SAC defaults, with the section's keys laid over.
    nlohmann::json sac = a.sac;
    if (!s->is_object()) throw std::invalid_argument("config section 'adversary.sac' must be a JSON object");
    for (auto it = s->begin(); it != s->end(); ++it) sac[it.key()] = it.value();
    a.sac = sac.get<SacConfig>();
  }
  r.get("collision_bonus", a.collision_bonus, range::closed(0.0, 1e6));
  r.get("scale_floor", a.scale_floor, range::open_closed(0.0, 1e6));
  r.get("reward_cap", a.reward_cap, range::open_closed(0.0, 1e6));
  r.get("worst_states", a.worst_states, range::closed(1, 1000));
  r.finish();
  auto bad = [](const std::string& what) { throw std::invalid_argument("config: adversary." + what); };
  if (!(std::isfinite(a.collision_bonus) && a.collision_bonus >= 0)) bad("collision_bonus must be finite and >= 0");
  if (!(std::isfinite(a.scale_floor) && a.scale_floor > 0)) bad("scale_floor must be finite and > 0");
  if (!(std::isfinite(a.reward_cap) && a.reward_cap > 0)) bad("reward_cap must be finite and > 0");
  if (a.worst_states < 1 || a.worst_states > 1000) bad("worst_states must be in [1, 1000]");
  c = a;
}

AdversaryLearner::AdversaryLearner(const LearnerContext& ctx, const AdversaryConfig& c)
    : cfg_(c),
      spec_(*ctx.spec),
      N_(ctx.num_envs),
      k_(ctx.spec->num_constraints),
      ni_(int(ctx.spec->info_names.size())),
      sac_(ctx, c.sac) {
  if (k_ < 1)
    throw std::invalid_argument("env '" + spec_.name + "' has no constraint rows: the adversary has nothing to attack");
  // Row scales from the training envs' first states.
  scale_.assign(size_t(k_), 0.0);
  for (int r = 0; r < k_; ++r) {
    double s = 0;
    int n = 0;
    for (int i = 0; i < N_; ++i) {
      const double v = ctx.initial->constraints[size_t(i) * k_ + r];
      if (std::isfinite(v)) { s += std::abs(v); ++n; }
    }
    scale_[size_t(r)] = std::max(cfg_.scale_floor, n ? s / n : 0.0);
  }
  for (int col = 0; col < ni_; ++col)
    if (is_contact(spec_.role(size_t(col)))) collision_cols_.push_back(col);
  reward_.assign(size_t(N_), 0.0f);
  current_.resize(size_t(N_));
}

void AdversaryLearner::observe(const float* obs, const double* actions, const EnvBuffers& b) {
  const int D = spec_.obs_dim;
  steps_ += N_;
  for (int i = 0; i < N_; ++i) {
    const double* c = &b.constraints[size_t(i) * k_];
    double scaled = -1e300, raw = -1e300;
    int raw_row = -1;
    for (int r = 0; r < k_; ++r) {
      if (!std::isfinite(c[r])) continue;
      scaled = std::max(scaled, c[r] / scale_[size_t(r)]);
      if (c[r] > raw) { raw = c[r]; raw_row = r; }
    }
    bool hit = false;
    for (int col : collision_cols_) hit = hit || b.info[size_t(i) * ni_ + col] > 0.0f;
    const double rew = (raw_row >= 0 ? std::min(scaled, cfg_.reward_cap) : 0.0) + (hit ? cfg_.collision_bonus : 0.0);
    reward_[size_t(i)] = float(rew);
    reward_sum_ += rew;
    ++reward_n_;
    if (raw_row >= 0 && raw > max_c_) { max_c_ = raw; max_row_ = raw_row; }
    Record& cur = current_[size_t(i)];
    if (raw_row >= 0 && raw > cur.value) {
      cur.value = raw;
      cur.row = raw_row;
      cur.env = i;
      cur.env_steps = steps_;
      cur.obs.assign(b.final_obs.begin() + ptrdiff_t(i) * D, b.final_obs.begin() + ptrdiff_t(i + 1) * D);
      cur.c.assign(c, c + k_);
    }
    if (b.done(i)) {
      if (cur.row >= 0) keep(worst_, cur, cfg_.worst_states);
      cur = Record{};
    }
  }
  sac_.observe_rewarded(obs, actions, b, reward_.data());
}

void AdversaryLearner::keep(std::vector<Record>& list, const Record& r, int cap) {
  // Largest value first; among equals the earlier one stays ahead.
  auto pos = std::upper_bound(list.begin(), list.end(), r,
                              [](const Record& a, const Record& b) { return a.value > b.value; });
  if (pos - list.begin() >= cap) return;
  list.insert(pos, r);
  if (int(list.size()) > cap) list.pop_back();
}

std::vector<std::string> AdversaryLearner::progress_columns() const {
  std::vector<std::string> c = sac_.progress_columns();
  c.push_back("adversary_reward");
  c.push_back("adversary_max_constraint");
  return c;
}

std::vector<double> AdversaryLearner::progress_values() {
  std::vector<double> v = sac_.progress_values();
  v.push_back(reward_n_ ? reward_sum_ / double(reward_n_) : std::nan(""));
  v.push_back(max_row_ >= 0 ? max_c_ : std::nan(""));
  reward_sum_ = 0;
  reward_n_ = 0;
  return v;
}

nlohmann::json AdversaryLearner::record_json(const Record& r) const {
  return {{"max_constraint", jnum(r.value)},
          {"row", r.row >= 0 && size_t(r.row) < spec_.constraint_names.size() ? spec_.constraint_names[size_t(r.row)]
                                                                             : std::to_string(r.row)},
          {"env", r.env},
          {"env_steps", r.env_steps},
          {"obs", r.obs},
          {"constraints", r.c}};
}

nlohmann::json AdversaryLearner::summary() const {
  // The finished episodes' worst plus those of the episodes still running.
  std::vector<Record> all = worst_;
  for (const Record& r : current_)
    if (r.row >= 0) keep(all, r, cfg_.worst_states);
  nlohmann::json worst = nlohmann::json::array();
  for (const Record& r : all) worst.push_back(record_json(r));
  nlohmann::json s = sac_.summary();
  s["adversary"] = {{"max_constraint", max_row_ >= 0 ? jnum(max_c_) : nlohmann::json(nullptr)},
                    {"max_constraint_row", max_row_ >= 0 ? nlohmann::json(spec_.constraint_names[size_t(max_row_)])
                                                         : nlohmann::json(nullptr)},
                    {"row_scale", scale_},
                    {"worst", worst}};
  return s;
}

nlohmann::json AdversaryLearner::manifest() const {
  nlohmann::json m = sac_.manifest();
  m["max_constraint"] = max_row_ >= 0 ? jnum(max_c_) : nlohmann::json(nullptr);
  return m;
}

void AdversaryLearner::save_record(std::ostream& out, const Record& r) {
  bin::write_pod(out, r.value);
  bin::write_pod(out, r.row);
  bin::write_pod(out, r.env);
  bin::write_pod(out, r.env_steps);
  bin::write_vec(out, r.obs);
  bin::write_vec(out, r.c);
}

AdversaryLearner::Record AdversaryLearner::load_record(std::istream& in) const {
  Record r;
  r.value = bin::read_pod<double>(in, "adversary.record");
  r.row = bin::read_pod<int32_t>(in, "adversary.record");
  r.env = bin::read_pod<int32_t>(in, "adversary.record");
  r.env_steps = bin::read_pod<int64_t>(in, "adversary.record");
  const bool set = r.row >= 0;
  bin::read_vec(in, r.obs, "adversary.record.obs", set ? spec_.obs_dim : 0);
  bin::read_vec(in, r.c, "adversary.record.constraints", set ? k_ : 0);
  if (set && (r.row >= k_ || r.env < 0 || r.env >= N_ || r.env_steps < 1 || r.env_steps > steps_ ||
              !std::isfinite(r.value)))
    throw std::runtime_error("adversary state: a worst-state record is out of range");
  if (!set && r.row != -1) throw std::runtime_error("adversary state: a worst-state record is out of range");
  return r;
}

void AdversaryLearner::save(std::ostream& out) const {
  bin::write_tag(out, kTagAdversary);
  bin::write_pod(out, steps_);
  bin::write_vec(out, scale_);
  bin::write_pod(out, max_c_);
  bin::write_pod(out, max_row_);
  bin::write_pod(out, reward_sum_);
  bin::write_pod(out, reward_n_);
  for (const Record& r : current_) save_record(out, r);
  bin::write_pod<int32_t>(out, int32_t(worst_.size()));
  for (const Record& r : worst_) save_record(out, r);
  sac_.save(out);
}

void AdversaryLearner::load(std::istream& in, int64_t env_steps) {
  bin::expect_tag(in, kTagAdversary, "adversary");
  steps_ = bin::read_pod<int64_t>(in, "adversary.steps");
  if (steps_ != env_steps)
    throw std::runtime_error("adversary state: observed " + std::to_string(steps_) + " env steps, the run " +
                             std::to_string(env_steps));
  bin::read_vec(in, scale_, "adversary.row_scale", k_);
  for (double s : scale_)
    if (!(std::isfinite(s) && s > 0)) throw std::runtime_error("adversary state: a row scale is not a positive number");
  max_c_ = bin::read_pod<double>(in, "adversary.max_constraint");
  max_row_ = bin::read_pod<int32_t>(in, "adversary.max_row");
  if (max_row_ < -1 || max_row_ >= k_ || (max_row_ >= 0 && !std::isfinite(max_c_)))
    throw std::runtime_error("adversary state: the largest constraint value is out of range");
  reward_sum_ = bin::read_pod<double>(in, "adversary.reward_sum");
  reward_n_ = bin::read_pod<int64_t>(in, "adversary.reward_n");
  if (!std::isfinite(reward_sum_) || reward_n_ < 0 || reward_n_ > steps_)
    throw std::runtime_error("adversary state: the reward window is out of range");
  for (Record& r : current_) r = load_record(in);
  const auto nw = bin::read_pod<int32_t>(in, "adversary.worst");
  if (nw < 0 || nw > cfg_.worst_states) throw std::runtime_error("adversary state: too many worst-state records");
  worst_.clear();
  for (int32_t w = 0; w < nw; ++w) worst_.push_back(load_record(in));
  sac_.load(in, env_steps);
}

uint64_t AdversaryLearner::state_hash() const {
  std::ostringstream s;
  save(s);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

nlohmann::json attack_result(const nlohmann::json& s) {
  auto get = [&](const char* k) { return s.contains(k) ? s[k] : nlohmann::json(nullptr); };
  const nlohmann::json adv = s.contains("adversary") ? s["adversary"] : nlohmann::json::object();
  const double wall = s.value("wall_s", 0.0);
  const int64_t steps = s.value("env_steps", int64_t{0});
  return {{"env", get("env")},
          {"algo", get("algo")},
          {"safety", get("safety")},
          {"seed", get("seed")},
          {"steps", steps},
          {"episodes", get("train_episodes")},
          {"terminations", get("train_terminations")},
          {"collisions", s.contains("train_collisions") ? s["train_collisions"] : nlohmann::json(0)},
          {"violations", get("train_violations")},
          {"max_constraint", get("train_max_constraint")},
          {"max_constraint_row", adv.contains("max_constraint_row") ? adv["max_constraint_row"] : nlohmann::json(nullptr)},
          {"worst", adv.contains("worst") ? adv["worst"] : nlohmann::json::array()},
          {"wall_s", wall},
          {"per_s", wall > 0 ? nlohmann::json(double(steps) / wall) : nlohmann::json(nullptr)}};
}

nlohmann::json adversary_default_config_json() { return default_adversary_config(); }

nlohmann::json adversary_resolve_config(const nlohmann::json& section) {
  return nlohmann::json(section.get<AdversaryConfig>());
}

std::unique_ptr<Learner> make_adversary_learner(const LearnerContext& ctx, const nlohmann::json& resolved) {
  return std::make_unique<AdversaryLearner>(ctx, resolved.get<AdversaryConfig>());
}

std::unique_ptr<Policy> make_adversary_policy(const EnvSpec& spec, const nlohmann::json& resolved) {
  return std::make_unique<SacPolicy>(spec, resolved.get<AdversaryConfig>().sac);
}
}  // namespace atacom
