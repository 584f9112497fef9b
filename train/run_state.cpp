#include "train/run_state.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/limits.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagCounters = 0x434e5452;  // "CNTR"
constexpr uint32_t kTagLearner = 0x4c524e52;   // "LRNR"
constexpr uint32_t kTagStreams = 0x5354524d;   // "STRM"
constexpr uint32_t kTagEnv = 0x454e5653;       // "ENVS"
constexpr uint32_t kTagEpisodeSteps = 0x45505354;  // "EPST"
constexpr uint32_t kTagTrainCost = 0x54534f43;     // "COST"
constexpr uint64_t kActStream = uint64_t{1} << 32;  // action noise: stream kActStream + env id

// Evaluations a run must have written by env_steps: one per batch step that
// crossed a multiple of eval_every (a run whose budget was extended also
// holds the end-of-run rows of its earlier budgets, so this is a floor).
int64_t least_rows(const TrainConfig& t, int N, int64_t env_steps) {
  int64_t rows = 0, next = t.eval_every;
  for (int64_t s = N; s <= env_steps; s += N)
    if (s >= next) {
      ++rows;
      while (next <= s) next += t.eval_every;
    }
  return rows;
}

void validate(const RunCounters& c, const TrainConfig& t, const std::vector<double>& sums, const nlohmann::json& best) {
  const int N = t.num_envs;
  auto bad = [](const std::string& what) { throw std::runtime_error("checkpoint counter " + what); };
  auto n = [](int64_t v) { return std::to_string(v); };
  if (c.env_steps < 1 || c.env_steps > limits::kMaxSteps || c.env_steps % N != 0)
    bad("env_steps = " + n(c.env_steps) + " is not a multiple of num_envs " + n(N) + " in [1, 10^12]");
  const int64_t want_eval = (c.env_steps / t.eval_every + 1) * t.eval_every;
  if (c.next_eval != want_eval)
    bad("next_eval = " + n(c.next_eval) + ", expected " + n(want_eval) + " after " + n(c.env_steps) + " steps");
  const int64_t want_ckpt = t.checkpoint_every > 0 ? (c.env_steps / t.checkpoint_every + 1) * t.checkpoint_every : 0;
  if (c.next_ckpt != want_ckpt)
    bad("next_ckpt = " + n(c.next_ckpt) + ", expected " + n(want_ckpt) + " after " + n(c.env_steps) + " steps");
  if (c.train_episodes < 0 || c.train_episodes > c.env_steps)
    bad("train_episodes = " + n(c.train_episodes) + " is outside [0, " + n(c.env_steps) + "]");
  if (c.train_terminations < 0 || c.train_terminations > c.train_episodes)
    bad("train_terminations = " + n(c.train_terminations) + " is outside [0, train_episodes]");
  if (c.train_violations < 0 || c.train_violations > c.env_steps)
    bad("train_violations = " + n(c.train_violations) + " is outside [0, " + n(c.env_steps) + "]");
  if (std::isnan(c.train_max_constraint) || c.train_max_constraint == std::numeric_limits<double>::infinity())
    bad("train_max_constraint is not a number");
  if (!(std::isfinite(c.wall_s) && c.wall_s >= 0)) bad("wall_s is not a finite number >= 0");
  if (!(std::isfinite(c.eval_wall_s) && c.eval_wall_s >= 0)) bad("eval_wall_s is not a finite number >= 0");
  if (c.target_env_steps == -1) {
    if (c.target_updates != -1 || !std::isnan(c.target_wall_s) || !std::isnan(c.target_train_cost))
      bad("target_updates, target_wall_s and target_train_cost are set while target_env_steps = -1 (never met)");
  } else if (c.target_env_steps < 1 || c.target_env_steps > c.env_steps || c.target_env_steps % N != 0 ||
             c.target_updates < 0 || !(std::isfinite(c.target_wall_s) && c.target_wall_s >= 0 && c.target_wall_s <= c.wall_s) ||
             !(std::isfinite(c.target_train_cost) && c.target_train_cost >= 0) || c.progress_rows < 1) {
    bad("target_env_steps = " + n(c.target_env_steps) + " (or its updates, wall time, cost) does not fit a run at " +
        n(c.env_steps) + " steps");
  }
  if (c.recent_returns < 0 || c.recent_returns > c.train_episodes) bad("recent_returns is outside [0, train_episodes]");
  if (!std::isfinite(c.recent_return_sum)) bad("recent_return_sum is not finite");
  if (std::isinf(c.last_train_return)) bad("last_train_return is infinite");
  const int64_t lo = least_rows(t, N, c.env_steps), hi = c.env_steps / N;
  if (c.progress_rows < lo || c.progress_rows > hi)
    bad("progress_rows = " + n(c.progress_rows) + " is outside [" + n(lo) + ", " + n(hi) + "] for " + n(c.env_steps) +
        " steps");
  for (double x : sums)
    if (!std::isfinite(x)) bad("train info sums hold a non-finite value");
  if (!best.is_null()) {
    if (!best.is_object() || !best.contains("env_steps") || !best["env_steps"].is_number_integer() ||
        best["env_steps"].get<int64_t>() < 1 || best["env_steps"].get<int64_t>() > c.env_steps ||
        c.progress_rows < 1)
      bad("best evaluation record is inconsistent");
  }
}
}  // namespace

void init_run_state(RunState& s, const TrainConfig& t, const EnvSpec& spec, const EnvBuffers& initial) {
  s.counters = RunCounters{};
  s.counters.next_eval = t.eval_every;
  s.counters.next_ckpt = t.checkpoint_every > 0 ? t.checkpoint_every : 0;
  s.train_info_sums.assign(spec.info_names.size(), 0.0);
  s.best = nullptr;
  s.train_episode_steps = 0;
  s.train_cost = 0;
  s.act_rngs.resize(size_t(t.num_envs));
  for (int i = 0; i < t.num_envs; ++i) s.act_rngs[size_t(i)].reseed(uint64_t(t.seed), kActStream + uint64_t(i));
  s.obs = initial.obs;
}

std::string save_run_payload(const RunState& s, const Learner& learner, const BatchEnv& env) {
  std::ostringstream p;
  RunCounters c = s.counters;
  bin::write_tag(p, kTagCounters);
  c.visit([&](auto& x) { bin::write_pod(p, x); });
  bin::write_vec(p, s.train_info_sums);
  const std::string best = s.best.dump();  // doubles print with 17 digits: exact round trip
  bin::write_vec(p, std::vector<char>(best.begin(), best.end()));
  bin::write_tag(p, kTagLearner);
  learner.save(p);
  bin::write_tag(p, kTagStreams);
  for (const Rng& r : s.act_rngs) bin::write_rng(p, r);
  bin::write_vec(p, s.obs);
  bin::write_tag(p, kTagEnv);
  env.save_state(p);
  bin::write_tag(p, kTagEpisodeSteps);
  bin::write_pod(p, s.train_episode_steps);
  bin::write_tag(p, kTagTrainCost);
  bin::write_pod(p, s.train_cost);
  return p.str();
}

void load_run_payload(const std::string& payload, const TrainConfig& t, const EnvSpec& spec, RunState& s,
                      Learner& learner, BatchEnv& env) {
  std::istringstream p(payload);
  RunState r = s;
  bin::expect_tag(p, kTagCounters, "counters");
  r.counters.visit([&](auto& x) { x = bin::read_pod<std::decay_t<decltype(x)>>(p, "counters"); });
  bin::read_vec(p, r.train_info_sums, "train_info_sums", int64_t(spec.info_names.size()));
  std::vector<char> best;
  bin::read_vec(p, best, "best evaluation");
  try {
    r.best = nlohmann::json::parse(best.begin(), best.end());
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error("checkpoint's best evaluation record is not JSON");
  }
  validate(r.counters, t, r.train_info_sums, r.best);
  bin::expect_tag(p, kTagLearner, "learner");
  learner.load(p, r.counters.env_steps);
  bin::expect_tag(p, kTagStreams, "streams");
  for (Rng& x : r.act_rngs) bin::read_rng(p, x, "action rng");
  bin::read_vec(p, r.obs, "obs", int64_t(t.num_envs) * spec.obs_dim);
  for (float x : r.obs)
    if (!std::isfinite(x)) throw std::runtime_error("checkpoint observation holds a non-finite value");
  bin::expect_tag(p, kTagEnv, "env");
  env.load_state(p);
  r.train_episode_steps = -1;  // checkpoints of earlier builds end here
  if (p.peek() != std::char_traits<char>::eof()) {
    bin::expect_tag(p, kTagEpisodeSteps, "episode steps");
    r.train_episode_steps = bin::read_pod<int64_t>(p, "episode steps");
    const int64_t v = r.train_episode_steps, lo = r.counters.train_episodes, hi = r.counters.env_steps;
    if (v != -1 && (v < lo || v > hi))
      throw std::runtime_error("checkpoint counter train_episode_steps = " + std::to_string(v) + " is outside [" +
                               std::to_string(lo) + ", " + std::to_string(hi) + "] (train_episodes, env_steps)");
  }
  r.train_cost = -1;  // and checkpoints of builds before the cost signal here
  if (p.peek() != std::char_traits<char>::eof()) {
    bin::expect_tag(p, kTagTrainCost, "training cost");
    r.train_cost = bin::read_pod<int64_t>(p, "training cost");
    if (r.train_cost != -1 && (r.train_cost < 0 || r.train_cost > r.counters.env_steps))
      throw std::runtime_error("checkpoint counter train_cost = " + std::to_string(r.train_cost) + " is outside [0, " +
                               std::to_string(r.counters.env_steps) + "] (env_steps)");
  }
  if (p.peek() != std::char_traits<char>::eof()) throw std::runtime_error("checkpoint payload is longer than its sections");
  s = std::move(r);
}

}  // namespace atacom
