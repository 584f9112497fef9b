#include "atacom/trainer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "train/checkpoint.hpp"
#include "src/core/config_json.hpp"
#include "atacom/env_registry.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/limits.hpp"
#include "train/replay_buffer.hpp"
#include "src/core/svg.hpp"

namespace atacom {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- config
TrainConfig default_train_config() { return TrainConfig{}; }

void to_json(nlohmann::json& j, const TrainConfig& c) {
  j = nlohmann::json{{"env", c.env}, {"algo", c.algo}, {"seed", c.seed}, {"steps", c.steps},
                     {"num_envs", c.num_envs}, {"eval_every", c.eval_every}, {"eval_episodes", c.eval_episodes},
                     {"eval_deterministic", c.eval_deterministic}, {"checkpoint_every", c.checkpoint_every}};
}

void from_json(const nlohmann::json& j, TrainConfig& c) {
  ConfigReader r(j, "train");
  r.get("env", c.env);
  r.get("algo", c.algo);
  r.get("seed", c.seed, range::at_least<int64_t>(0));
  r.get("steps", c.steps, range::closed<int64_t>(1, limits::kMaxSteps));
  r.get("num_envs", c.num_envs, range::closed(1, limits::kMaxEnvs));
  r.get("eval_every", c.eval_every, range::closed<int64_t>(1, limits::kMaxSteps));
  r.get("eval_episodes", c.eval_episodes, range::closed(1, limits::kMaxEvalEpisodes));
  r.get("eval_deterministic", c.eval_deterministic);
  r.get("checkpoint_every", c.checkpoint_every, range::closed<int64_t>(0, limits::kMaxSteps));
  r.finish();
}

namespace {
void validate(const TrainConfig& c) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("config: train." + what); };
  if (c.algo != "sac" && c.algo != "atacom-sac") bad("algo must be 'sac' or 'atacom-sac', got '" + c.algo + "'");
  if (c.seed < 0) bad("seed must be >= 0");
  if (c.steps < 1 || c.steps > limits::kMaxSteps) bad("steps must be in [1, 10^12]");
  if (c.num_envs < 1 || c.num_envs > (1 << 20)) bad("num_envs must be in [1, 2^20]");
  if (c.eval_every < 1 || c.eval_every > limits::kMaxSteps) bad("eval_every must be in [1, 10^12]");
  if (c.eval_episodes < 1 || c.eval_episodes > 100000) bad("eval_episodes must be in [1, 100000]");
  if (c.checkpoint_every < 0) bad("checkpoint_every must be >= 0");
  env_entry(c.env);  // unknown env names fail here, listing the known ones
}
}  // namespace

RunConfig resolve_run_config(const nlohmann::json& file, const TrainConfig* train_base) {
  ConfigReader r(file, "config");
  RunConfig c;
  c.train = train_base ? *train_base : default_train_config();
  if (const auto* t = r.sub("train")) from_json(*t, c.train);
  const nlohmann::json* s = r.sub("sac");
  const nlohmann::json* e = r.sub("env");
  r.finish();
  validate(c.train);
  // SAC: global defaults, then the env's own defaults for this algo, then the
  // file's keys (top-level keys replace, so "target_entropy": null still works).
  nlohmann::json sac = default_sac_config();
  if (const auto per_env = env_entry(c.train.env).default_sac) {
    const nlohmann::json d = per_env(c.train.algo == "atacom-sac" ? SafetyLayer::Atacom : SafetyLayer::None);
    for (auto it = d.begin(); it != d.end(); ++it) sac[it.key()] = it.value();
  }
  if (s) {
    if (!s->is_object()) throw std::invalid_argument("config section 'sac' must be a JSON object");
    for (auto it = s->begin(); it != s->end(); ++it) sac[it.key()] = it.value();
  }
  c.sac = sac.get<SacConfig>();
  c.env = resolve_env_config(c.train.env, e ? *e : nlohmann::json::object());
  return c;
}

nlohmann::json run_config_json(const RunConfig& c) {
  return nlohmann::json{{"env", c.env}, {"sac", c.sac}, {"train", c.train}};
}

std::vector<std::string> progress_columns(const std::vector<std::string>& info_names) {
  std::vector<std::string> cols = {"env_steps", "updates", "wall_s", "eval_return_mean", "eval_return_std",
                                   "train_episode_return", "alpha", "actor_loss", "critic_loss", "alpha_loss",
                                   "entropy", "q_mean"};
  cols.insert(cols.end(), info_names.begin(), info_names.end());
  cols.push_back("early_terminations");
  cols.push_back("avg_episode_steps");
  cols.push_back("violations");
  return cols;
}

// ---------------------------------------------------------------- SVG
std::string learning_curve_svg(const std::string& title, const std::vector<double>& steps,
                               const std::vector<double>& mean, const std::vector<double>& sd) {
  double x1 = 1, y0 = 0, y1 = 1;
  bool any = false;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (!std::isfinite(mean[i])) continue;
    const double s = std::isfinite(sd[i]) ? sd[i] : 0.0;
    if (!any) { y0 = mean[i] - s; y1 = mean[i] + s; any = true; }
    x1 = std::max(x1, steps[i]);
    y0 = std::min(y0, mean[i] - s);
    y1 = std::max(y1, mean[i] + s);
  }
  if (y1 - y0 < 1e-9) { y0 -= 1; y1 += 1; }
  // round the y range out to ticks at multiples of 1, 2 or 5 x 10^k
  const double raw = (y1 - y0) / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw <= mag ? mag : raw <= 2 * mag ? 2 * mag : raw <= 5 * mag ? 5 * mag : 10 * mag;
  const double lo = std::floor(y0 / step) * step;
  const int yticks = std::max(1, static_cast<int>(std::ceil((y1 - lo) / step - 1e-9)));
  SvgCanvas svg(640, 400, 0.0, x1, lo, lo + yticks * step, 64);
  svg.axes("env steps", "eval return (mean, mean +- std)", 5, yticks);
  svg.label(320, 24, title, 15, "middle");
  std::vector<std::pair<double, double>> line, up, down;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (!std::isfinite(mean[i])) continue;
    const double s = std::isfinite(sd[i]) ? sd[i] : 0.0;
    line.emplace_back(steps[i], mean[i]);
    up.emplace_back(steps[i], mean[i] + s);
    down.emplace_back(steps[i], mean[i] - s);
  }
  if (!line.empty()) {
    svg.polyline(up, "#1f77b4", 1.0, 0.35);
    svg.polyline(down, "#1f77b4", 1.0, 0.35);
    svg.polyline(line, "#1f77b4", 2.0);
    for (const auto& [x, y] : line) svg.circle(x, y, 0.006 * x1, "#1f77b4");  // one dot per evaluation
  }
  return svg.str();
}

// ---------------------------------------------------------------- the run
namespace {

constexpr uint32_t kTagCounters = 0x434e5452;  // "CNTR"
constexpr uint32_t kTagStreams = 0x5354524d;   // "STRM"
constexpr uint32_t kTagEnv = 0x454e5653;       // "ENVS"
constexpr uint64_t kActStream = uint64_t{1} << 32;  // action noise: stream kActStream + env id
constexpr uint64_t kEvalStream = uint64_t{2} << 32;
constexpr uint64_t kReplayStream = uint64_t{3} << 32;
constexpr uint64_t kEvalSeedSalt = 0x5EEDE7A15EEDE7A1ull;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  char b[40];
  std::snprintf(b, sizeof(b), "%.9g", v);
  return b;
}

std::string hex(uint64_t h) {
  char b[20];
  std::snprintf(b, sizeof(b), "%016llx", static_cast<unsigned long long>(h));
  return b;
}

std::string duration(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char b[32];
  if (s < 60) std::snprintf(b, sizeof(b), "%.0fs", s);
  else if (s < 3600) std::snprintf(b, sizeof(b), "%dm%02ds", int(s) / 60, int(s) % 60);
  else std::snprintf(b, sizeof(b), "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  return b;
}

// Observation normalisation from the spec's bounds to [-1, 1] (clipped to
// +-10, as the paper's MinMax preprocessor); dims without finite, ordered
// bounds pass through unchanged.
struct ObsNorm {
  int d = 0;
  std::vector<float> mid, inv_half;  // (d)
  std::vector<uint8_t> on;           // (d)
  void init(const EnvSpec& s, bool enabled) {
    d = s.obs_dim;
    mid.assign(size_t(d), 0.0f);
    inv_half.assign(size_t(d), 1.0f);
    on.assign(size_t(d), 0);
    if (!enabled || s.obs_low.size() != size_t(d) || s.obs_high.size() != size_t(d)) return;
    for (int j = 0; j < d; ++j) {
      const float lo = s.obs_low[size_t(j)], hi = s.obs_high[size_t(j)];
      if (std::isfinite(lo) && std::isfinite(hi) && hi > lo) {
        mid[size_t(j)] = 0.5f * (lo + hi);
        inv_half[size_t(j)] = 2.0f / (hi - lo);
        on[size_t(j)] = 1;
      }
    }
  }
  void apply(const float* in, float* out, int n) const {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < d; ++j) {
        const size_t k = size_t(i) * d + j;
        out[k] = on[size_t(j)] ? std::min(std::max((in[k] - mid[size_t(j)]) * inv_half[size_t(j)], -10.0f), 10.0f)
                               : in[k];
      }
  }
};

// Everything the loop counts; visited field by field for checkpoints.
struct Counters {
  int64_t env_steps = 0, updates = 0, next_eval = 0, next_ckpt = 0;
  int64_t train_episodes = 0, train_terminations = 0;
  int64_t train_violations = 0;  // env-steps with some constraint row above its tolerance
  double budget = 0, wall_s = 0;
  // since the last evaluation
  int64_t n_critic = 0, n_actor = 0, recent_returns = 0;
  double critic_loss = 0, actor_loss = 0, alpha_loss = 0, entropy = 0, q_mean = 0, recent_return_sum = 0;
  double last_train_return = kNaN;
  uint64_t progress_bytes = 0;

  template <class F>
  void visit(F&& f) {
    f(env_steps); f(updates); f(next_eval); f(next_ckpt); f(train_episodes); f(train_terminations);
    f(budget); f(wall_s); f(n_critic); f(n_actor); f(recent_returns); f(critic_loss); f(actor_loss);
    f(alpha_loss); f(entropy); f(q_mean); f(recent_return_sum); f(last_train_return); f(progress_bytes);
    f(train_violations);
  }
};

class Run {
 public:
  // Does env i's state violate some constraint row beyond its stated tolerance?
  bool violated(const EnvBuffers& b, int i) const {
    const int k = spec_.num_constraints;
    for (int r = 0; r < k; ++r)
      if (b.constraints[size_t(i) * k + r] > spec_.constraint_tolerance[size_t(r)]) return true;
    return false;
  }

  Run(const RunConfig& cfg, const TrainOptions& opts);
  TrainSummary go();

 private:
  void step_and_learn();
  EvalResult evaluate();
  void write_progress_row(const EvalResult& ev);
  void save_checkpoint();
  void load_checkpoint();
  void redraw_svg();
  void print_progress(bool force, const EvalResult* ev);
  nlohmann::json summary_json(const EvalResult& ev) const;
  uint64_t config_hash() const;
  double wall() const {
    return counters_.wall_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  std::string path(const char* name) const { return (fs::path(opts_.out_dir) / name).string(); }

  RunConfig cfg_;
  TrainOptions opts_;
  std::unique_ptr<BatchEnv> env_, eval_env_;
  EnvSpec spec_;
  int N_, D_, A_, ninfo_;
  ObsNorm norm_;
  std::unique_ptr<Sac> sac_;
  ReplayBuffer replay_;
  ReplayBatch batch_;
  Rng replay_rng_;
  std::vector<Rng> act_rngs_;       // (N) action noise streams
  std::vector<Rng> eval_rngs_;      // (eval_episodes)
  std::vector<float> obs_;          // (N x D) normalised observation to act on
  std::vector<float> next_obs_;     // (N x D) normalised final_obs of the last step
  std::vector<float> new_obs_;      // (N x D) normalised obs after autoreset
  std::vector<double> actions_;     // (N x A)
  std::vector<double> train_info_sums_;  // (n_info) summed over all training steps
  Counters counters_;
  std::chrono::steady_clock::time_point start_, last_print_;
  double eval_s_ = 0;               // wall time spent evaluating (excluded from steps/s)
  int64_t steps_at_start_ = 0;
  double last_eval_return_ = kNaN;
  int64_t last_ckpt_steps_ = -1;    // env_steps of the newest checkpoint written by this process
  std::vector<double> hist_steps_, hist_mean_, hist_std_;
  // evaluation scratch
  std::vector<float> eobs_;
  std::vector<double> eact_, eret_, einfo_;
  std::vector<int> elen_;
  std::vector<uint8_t> edone_, eterm_;
  std::vector<int32_t> eviol_;  // (eval episodes) steps with a constraint row above its tolerance
};

Run::Run(const RunConfig& cfg, const TrainOptions& opts) : cfg_(cfg), opts_(opts) {
  const TrainConfig& t = cfg_.train;
  validate(t);
  const SafetyLayer safety = t.algo == "atacom-sac" ? SafetyLayer::Atacom : SafetyLayer::None;
  env_ = make_env(EnvRequest{t.env, t.num_envs, safety, cfg_.env});
  eval_env_ = make_env(EnvRequest{t.env, t.eval_episodes, safety, cfg_.env});
  spec_ = env_->spec();
  N_ = t.num_envs;
  D_ = spec_.obs_dim;
  A_ = spec_.act_dim;
  ninfo_ = static_cast<int>(spec_.info_names.size());
  if (D_ < 1 || A_ < 1) throw std::invalid_argument("env '" + t.env + "' reports empty observation or action space");
  if (spec_.info_reduce.size() != spec_.info_names.size())
    throw std::invalid_argument("env '" + t.env + "' spec: info_reduce and info_names differ in length");
  if (cfg_.sac.replay_capacity < cfg_.sac.batch_size)
    throw std::invalid_argument("config: sac.replay_capacity must be >= sac.batch_size");
  norm_.init(spec_, cfg_.sac.obs_norm);
  sac_ = std::make_unique<Sac>(D_, A_, cfg_.sac, uint64_t(t.seed));
  replay_ = ReplayBuffer(cfg_.sac.replay_capacity, D_, A_);
  batch_.resize(cfg_.sac.batch_size, D_, A_);
  replay_rng_.reseed(uint64_t(t.seed), kReplayStream);
  act_rngs_.resize(size_t(N_));
  for (int i = 0; i < N_; ++i) act_rngs_[size_t(i)].reseed(uint64_t(t.seed), kActStream + uint64_t(i));
  eval_rngs_.resize(size_t(t.eval_episodes));
  obs_.assign(size_t(N_) * D_, 0.0f);
  next_obs_ = new_obs_ = obs_;
  actions_.assign(size_t(N_) * A_, 0.0);
  train_info_sums_.assign(size_t(ninfo_), 0.0);
  const int M = t.eval_episodes;
  eobs_.assign(size_t(M) * D_, 0.0f);
  eact_.assign(size_t(M) * A_, 0.0);
  eret_.assign(size_t(M), 0.0);
  einfo_.assign(size_t(M) * ninfo_, 0.0);
  elen_.assign(size_t(M), 0);
  edone_.assign(size_t(M), 0);
  eterm_.assign(size_t(M), 0);
  eviol_.assign(size_t(M), 0);
  env_->seed(uint64_t(t.seed));
  norm_.apply(env_->buffers().obs.data(), obs_.data(), N_);
  counters_.next_eval = t.eval_every;
  counters_.next_ckpt = t.checkpoint_every > 0 ? t.checkpoint_every : 0;
}

uint64_t Run::config_hash() const {
  nlohmann::json j = run_config_json(cfg_);
  j["train"].erase("steps");  // a resumed run may extend its budget
  const std::string s = j.dump();
  return bin::fnv1a(s.data(), s.size());
}

void Run::step_and_learn() {
  const TrainConfig& t = cfg_.train;
  sac_->act(obs_.data(), N_, false, act_rngs_.data(), actions_.data());
  env_->step(actions_.data());
  const EnvBuffers& b = env_->buffers();
  for (int i = 0; i < N_; ++i) {
    bool ok = std::isfinite(b.reward[size_t(i)]) && std::isfinite(b.cost[size_t(i)]);
    for (int j = 0; j < D_; ++j)
      ok = ok && std::isfinite(b.obs[size_t(i) * D_ + j]) && std::isfinite(b.final_obs[size_t(i) * D_ + j]);
    if (!ok)
      throw std::runtime_error("env '" + t.env + "' returned a non-finite observation, reward or cost (env " +
                               std::to_string(i) + ", env step " + std::to_string(counters_.env_steps) + ")");
  }
  norm_.apply(b.final_obs.data(), next_obs_.data(), N_);
  norm_.apply(b.obs.data(), new_obs_.data(), N_);
  replay_.add(N_, obs_.data(), actions_.data(), b.reward.data(), b.cost.data(), next_obs_.data(),
              b.terminated.data(), b.truncated.data());
  for (int i = 0; i < N_; ++i) {
    for (int c = 0; c < ninfo_; ++c)
      if (spec_.info_reduce[size_t(c)] == InfoReduce::Sum) train_info_sums_[size_t(c)] += b.info[size_t(i) * ninfo_ + c];
    counters_.train_violations += violated(b, i);
    if (b.done(i)) {
      ++counters_.train_episodes;
      if (b.terminated[size_t(i)]) ++counters_.train_terminations;
      counters_.recent_return_sum += b.episode_return[size_t(i)];
      ++counters_.recent_returns;
      counters_.last_train_return = b.episode_return[size_t(i)];
    }
  }
  obs_.swap(new_obs_);
  counters_.env_steps += N_;
  counters_.budget += cfg_.sac.updates_per_step * N_;
  while (counters_.budget >= 1.0) {
    counters_.budget -= 1.0;
    if (replay_.size() <= cfg_.sac.initial_replay || replay_.size() < cfg_.sac.batch_size) continue;
    replay_.sample(replay_rng_, batch_);
    const SacStats st = sac_->update(batch_, replay_.size() > cfg_.sac.warmup);
    ++counters_.updates;
    ++counters_.n_critic;
    counters_.critic_loss += st.critic_loss;
    counters_.q_mean += st.q_mean;
    if (st.actor_updated) {
      ++counters_.n_actor;
      counters_.actor_loss += st.actor_loss;
      counters_.alpha_loss += st.alpha_loss;
      counters_.entropy += st.entropy;
    }
  }
}

EvalResult Run::evaluate() {
  const auto t0 = std::chrono::steady_clock::now();
  const TrainConfig& t = cfg_.train;
  const int M = t.eval_episodes;
  BatchEnv& e = *eval_env_;
  e.seed(uint64_t(t.seed) ^ kEvalSeedSalt);  // the same start states at every evaluation
  for (int i = 0; i < M; ++i) eval_rngs_[size_t(i)].reseed(uint64_t(t.seed), kEvalStream + uint64_t(i));
  std::fill(eret_.begin(), eret_.end(), 0.0);
  std::fill(elen_.begin(), elen_.end(), 0);
  std::fill(edone_.begin(), edone_.end(), 0);
  std::fill(eterm_.begin(), eterm_.end(), 0);
  std::fill(eviol_.begin(), eviol_.end(), 0);
  for (int i = 0; i < M; ++i)
    for (int c = 0; c < ninfo_; ++c)
      einfo_[size_t(i) * ninfo_ + c] =
          spec_.info_reduce[size_t(c)] == InfoReduce::Max ? -std::numeric_limits<double>::infinity() : 0.0;
  const EnvBuffers& b = e.buffers();
  norm_.apply(b.obs.data(), eobs_.data(), M);
  const int cap = spec_.horizon > 0 ? spec_.horizon : 100000;  // envs without a horizon stop here
  int remaining = M;
  for (int step = 0; step < cap && remaining > 0; ++step) {
    sac_->act(eobs_.data(), M, t.eval_deterministic, eval_rngs_.data(), eact_.data());
    e.step(eact_.data());
    for (int i = 0; i < M; ++i) {
      if (edone_[size_t(i)]) continue;
      eret_[size_t(i)] += b.reward[size_t(i)];
      ++elen_[size_t(i)];
      eviol_[size_t(i)] += violated(b, i);
      for (int c = 0; c < ninfo_; ++c) {
        double& acc = einfo_[size_t(i) * ninfo_ + c];
        const double v = b.info[size_t(i) * ninfo_ + c];
        switch (spec_.info_reduce[size_t(c)]) {
          case InfoReduce::Last: acc = v; break;
          case InfoReduce::Sum: case InfoReduce::Mean: acc += v; break;
          case InfoReduce::Max: acc = std::max(acc, v); break;
        }
      }
      if (b.done(i)) {
        edone_[size_t(i)] = 1;
        eterm_[size_t(i)] = b.terminated[size_t(i)];
        --remaining;
      }
    }
    norm_.apply(b.obs.data(), eobs_.data(), M);
  }
  EvalResult r;
  r.episodes = M;
  r.info.assign(size_t(ninfo_), 0.0);
  double s = 0, s2 = 0, len = 0;
  for (int i = 0; i < M; ++i) {
    s += eret_[size_t(i)];
    len += elen_[size_t(i)];
    r.early_terminations += eterm_[size_t(i)];
    r.violations += double(eviol_[size_t(i)]) / M;
    for (int c = 0; c < ninfo_; ++c) {
      double v = einfo_[size_t(i) * ninfo_ + c];
      if (spec_.info_reduce[size_t(c)] == InfoReduce::Mean) v /= std::max(1, elen_[size_t(i)]);
      r.info[size_t(c)] += v / M;
    }
  }
  r.return_mean = s / M;
  for (int i = 0; i < M; ++i) s2 += (eret_[size_t(i)] - r.return_mean) * (eret_[size_t(i)] - r.return_mean);
  r.return_std = std::sqrt(s2 / M);
  r.avg_episode_steps = len / M;
  eval_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

void Run::write_progress_row(const EvalResult& ev) {
  Counters& c = counters_;
  const double train_ret = c.recent_returns > 0 ? c.recent_return_sum / double(c.recent_returns) : c.last_train_return;
  std::vector<double> row = {double(c.env_steps), double(c.updates), wall(), ev.return_mean, ev.return_std, train_ret,
                             sac_->alpha(),
                             c.n_actor ? c.actor_loss / double(c.n_actor) : kNaN,
                             c.n_critic ? c.critic_loss / double(c.n_critic) : kNaN,
                             c.n_actor ? c.alpha_loss / double(c.n_actor) : kNaN,
                             c.n_actor ? c.entropy / double(c.n_actor) : kNaN,
                             c.n_critic ? c.q_mean / double(c.n_critic) : kNaN};
  row.insert(row.end(), ev.info.begin(), ev.info.end());
  row.push_back(ev.early_terminations);
  row.push_back(ev.avg_episode_steps);
  row.push_back(ev.violations);
  std::string line;
  for (size_t k = 0; k < row.size(); ++k) {
    if (k) line += ',';
    line += fmt(row[k]);
  }
  line += "\n";
  {
    std::ofstream f(path("progress.csv"), std::ios::app | std::ios::binary);
    f << line;
    f.flush();
    if (!f) throw std::runtime_error("cannot append to " + path("progress.csv"));
  }
  c.progress_bytes = uint64_t(fs::file_size(path("progress.csv")));
  c.n_critic = c.n_actor = c.recent_returns = 0;
  c.critic_loss = c.actor_loss = c.alpha_loss = c.entropy = c.q_mean = c.recent_return_sum = 0;
  hist_steps_.push_back(double(c.env_steps));
  hist_mean_.push_back(ev.return_mean);
  hist_std_.push_back(ev.return_std);
  last_eval_return_ = ev.return_mean;
  redraw_svg();
}

void Run::redraw_svg() {
  const TrainConfig& t = cfg_.train;
  write_file_atomic(path("progress.svg"),
                    learning_curve_svg(t.env + " / " + t.algo + " / seed " + std::to_string(t.seed), hist_steps_,
                                       hist_mean_, hist_std_));
}

void Run::save_checkpoint() {
  std::ostringstream p;
  Counters c = counters_;
  c.wall_s = wall();
  bin::write_tag(p, kTagCounters);
  c.visit([&](auto& x) { bin::write_pod(p, x); });
  bin::write_vec(p, train_info_sums_);
  sac_->save(p);
  replay_.save(p);
  bin::write_tag(p, kTagStreams);
  bin::write_rng(p, replay_rng_);
  for (const Rng& r : act_rngs_) bin::write_rng(p, r);
  bin::write_vec(p, obs_);
  bin::write_tag(p, kTagEnv);
  env_->save_state(p);
  Checkpoint ck;
  ck.payload = p.str();
  ck.manifest = {{"format", "atacom-checkpoint"}, {"version", kCheckpointVersion},
                 {"env", cfg_.train.env}, {"algo", cfg_.train.algo}, {"seed", cfg_.train.seed},
                 {"env_steps", c.env_steps}, {"updates", c.updates}, {"wall_s", c.wall_s},
                 {"replay_size", replay_.size()}, {"alpha", sac_->alpha()},
                 {"agent_hash", hex(sac_->state_hash())}, {"config_hash", hex(config_hash())},
                 {"payload_sections", {"counters", "sac", "replay", "streams", "env"}}};
  write_checkpoint_atomic(path("checkpoint.bin"), ck);
  write_file_atomic(path("checkpoint.json"), ck.manifest.dump(2) + "\n");
  last_ckpt_steps_ = c.env_steps;
}

void Run::load_checkpoint() {
  const Checkpoint ck = read_checkpoint(path("checkpoint.bin"));
  if (ck.manifest.value("config_hash", "") != hex(config_hash()))
    throw std::runtime_error("checkpoint in '" + opts_.out_dir + "' was written with a different config");
  std::istringstream p(ck.payload);
  try {
    bin::expect_tag(p, kTagCounters, "counters");
    counters_.visit([&](auto& x) { x = bin::read_pod<std::decay_t<decltype(x)>>(p, "counters"); });
    bin::read_vec(p, train_info_sums_, "train_info_sums", ninfo_);
    sac_->load(p);
    replay_.load(p);
    bin::expect_tag(p, kTagStreams, "streams");
    bin::read_rng(p, replay_rng_, "replay rng");
    for (Rng& r : act_rngs_) bin::read_rng(p, r, "action rng");
    bin::read_vec(p, obs_, "obs", int64_t(N_) * D_);
    bin::expect_tag(p, kTagEnv, "env");
    env_->load_state(p);
  } catch (const std::exception& e) {
    throw std::runtime_error("checkpoint in '" + opts_.out_dir + "' cannot be restored: " + e.what());
  }
  // Drop evaluation rows written after the checkpoint (the run was killed
  // after them); they will be produced again, identically.
  const std::string csv = path("progress.csv");
  if (!fs::exists(csv) || fs::file_size(csv) < counters_.progress_bytes)
    throw std::runtime_error("progress.csv in '" + opts_.out_dir + "' is shorter than the checkpoint expects");
  fs::resize_file(csv, counters_.progress_bytes);
  std::ifstream f(csv);
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line)) {
    std::istringstream ls(line);
    std::string cell;
    std::vector<double> v;
    while (std::getline(ls, cell, ',') && v.size() < 5) v.push_back(std::strtod(cell.c_str(), nullptr));
    if (v.size() < 5) continue;
    hist_steps_.push_back(v[0]);
    hist_mean_.push_back(v[3]);
    hist_std_.push_back(v[4]);
    last_eval_return_ = v[3];
  }
}

void Run::print_progress(bool force, const EvalResult* ev) {
  if (!opts_.log) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && (!opts_.log_is_tty || now - last_print_ < std::chrono::milliseconds(250))) return;
  last_print_ = now;
  const TrainConfig& t = cfg_.train;
  const double el = std::chrono::duration<double>(now - start_).count() - eval_s_;
  const double sps = el > 0 ? double(counters_.env_steps - steps_at_start_) / el : 0.0;
  const double eta = sps > 0 ? double(t.steps - counters_.env_steps) / sps : kNaN;
  char b[256];
  std::snprintf(b, sizeof(b), "%s/%s seed %lld: %lld/%lld steps  %.0f steps/s  ETA %s  last return %s  eval %s",
                t.env.c_str(), t.algo.c_str(), static_cast<long long>(t.seed),
                static_cast<long long>(counters_.env_steps), static_cast<long long>(t.steps), sps,
                duration(eta).c_str(), fmt(counters_.last_train_return).c_str(),
                fmt(ev ? ev->return_mean : last_eval_return_).c_str());
  if (opts_.log_is_tty) *opts_.log << "\r\033[K" << b << std::flush;
  else *opts_.log << b << "\n" << std::flush;
}

nlohmann::json Run::summary_json(const EvalResult& ev) const {
  const TrainConfig& t = cfg_.train;
  auto jnum = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json s = {{"env", t.env}, {"algo", t.algo}, {"seed", t.seed},
                      {"eval_return_mean", jnum(ev.return_mean)}, {"eval_return_std", jnum(ev.return_std)},
                      {"eval_episodes", ev.episodes}, {"eval_deterministic", t.eval_deterministic},
                      {"env_steps", counters_.env_steps}, {"updates", counters_.updates}, {"wall_s", wall()},
                      {"alpha", jnum(sac_->alpha())}, {"early_terminations", ev.early_terminations},
                      {"avg_episode_steps", ev.avg_episode_steps}, {"train_episodes", counters_.train_episodes},
                      {"train_terminations", counters_.train_terminations},
                      {"violations", ev.violations}, {"train_violations", counters_.train_violations},
                      {"agent_hash", hex(sac_->state_hash())}};
  for (int c = 0; c < ninfo_; ++c) {
    const std::string& name = spec_.info_names[size_t(c)];
    s[name] = jnum(ev.info[size_t(c)]);
    if (spec_.info_reduce[size_t(c)] == InfoReduce::Sum) s["train_" + name] = jnum(train_info_sums_[size_t(c)]);
    // Collision counts also under the plural names the rollout command and
    // the issues use: collisions, wall_collisions, train_collisions, ...
    if (name.size() >= 9 && name.compare(name.size() - 9, 9, "collision") == 0) {
      s[name + "s"] = jnum(ev.info[size_t(c)]);
      if (spec_.info_reduce[size_t(c)] == InfoReduce::Sum) s["train_" + name + "s"] = jnum(train_info_sums_[size_t(c)]);
    }
  }
  return s;
}

TrainSummary Run::go() {
  const TrainConfig& t = cfg_.train;
  const fs::path dir(opts_.out_dir);
  const bool has_ckpt = fs::exists(dir / "checkpoint.bin");
  if (opts_.resume && has_ckpt) {
    load_checkpoint();
  } else {
    fs::create_directories(dir);
    std::string header;
    for (const auto& c : progress_columns(spec_.info_names)) {
      if (!header.empty()) header += ',';
      header += c;
    }
    write_file_atomic(path("progress.csv"), header + "\n");
    counters_.progress_bytes = header.size() + 1;
  }
  write_file_atomic(path("config.json"), run_config_json(cfg_).dump(2) + "\n");
  start_ = last_print_ = std::chrono::steady_clock::now();
  steps_at_start_ = counters_.env_steps;
  EvalResult last;
  bool have_eval = false;
  while (counters_.env_steps < t.steps) {
    step_and_learn();
    const bool end = counters_.env_steps >= t.steps;
    const bool stop = opts_.stop_after > 0 && counters_.env_steps >= opts_.stop_after;
    if (counters_.env_steps >= counters_.next_eval || end) {
      while (counters_.next_eval <= counters_.env_steps) counters_.next_eval += t.eval_every;
      last = evaluate();
      have_eval = true;
      write_progress_row(last);
      print_progress(true, &last);
      if (t.checkpoint_every == 0) save_checkpoint();
    } else {
      print_progress(false, nullptr);
    }
    if (t.checkpoint_every > 0 && (counters_.env_steps >= counters_.next_ckpt || end)) {
      while (counters_.next_ckpt <= counters_.env_steps) counters_.next_ckpt += t.checkpoint_every;
      save_checkpoint();
    }
    if (stop && !end) {
      if (last_ckpt_steps_ != counters_.env_steps) save_checkpoint();
      break;
    }
  }
  if (opts_.log && opts_.log_is_tty) *opts_.log << "\n";
  if (!have_eval) last = evaluate();  // resumed a finished run, or stopped early
  TrainSummary out;
  out.final_eval = last;
  out.env_steps = counters_.env_steps;
  out.updates = counters_.updates;
  out.wall_s = wall();
  out.agent_hash = sac_->state_hash();
  out.summary = summary_json(last);
  if (counters_.env_steps >= t.steps) write_file_atomic(path("summary.json"), out.summary.dump(2) + "\n");
  return out;
}

}  // namespace

TrainSummary run_training(const RunConfig& cfg, const TrainOptions& opts) {
  if (opts.out_dir.empty()) throw std::invalid_argument("training needs an output directory");
  const fs::path dir(opts.out_dir);
  if (fs::exists(dir) && !fs::is_directory(dir))
    throw std::invalid_argument("output path '" + opts.out_dir + "' exists and is not a directory");
  const bool nonempty = fs::exists(dir) && !fs::is_empty(dir);
  if (nonempty && !opts.resume)
    throw std::invalid_argument("output directory '" + opts.out_dir +
                                "' is not empty; pass --resume to continue that run or choose a new directory");
  remove_stale_temp_files(opts.out_dir);  // temp files a killed earlier process of this run left behind
  Run run(cfg, opts);  // builds envs and agent: config errors surface here, before any file is written
  return run.go();
}

}  // namespace atacom

namespace atacom {

struct TrainedPolicy::Impl {
  std::unique_ptr<Sac> sac;
  ObsNorm norm;
  std::vector<float> nobs;  // (N x obs_dim) normalised observations
  std::vector<Rng> rngs;    // unused by the mean action, required by Sac::act
};

TrainedPolicy::~TrainedPolicy() = default;
int TrainedPolicy::obs_dim() const { return impl_->sac->obs_dim(); }
int TrainedPolicy::act_dim() const { return impl_->sac->act_dim(); }

std::unique_ptr<TrainedPolicy> TrainedPolicy::load(const std::string& run_dir) {
  const fs::path dir(run_dir);
  std::ifstream cf(dir / "config.json");
  if (!cf) throw std::runtime_error("no config.json in run directory '" + run_dir + "'");
  nlohmann::json file;
  try {
    file = nlohmann::json::parse(cf);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("config.json in '" + run_dir + "' is not valid JSON: " + e.what());
  }
  std::unique_ptr<TrainedPolicy> tp(new TrainedPolicy());
  tp->cfg_ = resolve_run_config(file);
  tp->impl_ = std::make_unique<Impl>();
  const TrainConfig& t = tp->cfg_.train;
  // The env as training built it (ATACOM adds info columns), for the spec only.
  const auto env = make_env(EnvRequest{t.env, 1, t.algo == "atacom-sac" ? SafetyLayer::Atacom : SafetyLayer::None, tp->cfg_.env});
  const EnvSpec& spec = env->spec();
  tp->impl_->norm.init(spec, tp->cfg_.sac.obs_norm);
  tp->impl_->sac = std::make_unique<Sac>(spec.obs_dim, spec.act_dim, tp->cfg_.sac, uint64_t(t.seed));
  const Checkpoint ck = read_checkpoint((dir / "checkpoint.bin").string());
  std::istringstream p(ck.payload);
  try {
    bin::expect_tag(p, kTagCounters, "counters");
    Counters counters;
    counters.visit([&](auto& x) { x = bin::read_pod<std::decay_t<decltype(x)>>(p, "counters"); });
    std::vector<double> sums;
    bin::read_vec(p, sums, "train_info_sums", int64_t(spec.info_names.size()));
    tp->impl_->sac->load(p);
  } catch (const std::exception& e) {
    throw std::runtime_error("checkpoint in '" + run_dir + "' does not hold this run's agent: " + e.what());
  }
  return tp;
}

void TrainedPolicy::act(const float* obs, int N, double* actions) {
  Impl& m = *impl_;
  m.nobs.resize(size_t(N) * m.sac->obs_dim());
  if (m.rngs.size() != size_t(N)) m.rngs.assign(size_t(N), Rng(0, 0));
  m.norm.apply(obs, m.nobs.data(), N);
  m.sac->act(m.nobs.data(), N, true, m.rngs.data(), actions);
}

}  // namespace atacom
