// The trainer loop: builds the run's envs and its action source from the
// algorithm table, steps, hands transitions to the learner, evaluates,
// writes the run directory's files and checkpoints. It knows the learner
// and policy contracts only.
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

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/learner.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/host_info.hpp"
#include "src/core/json_number.hpp"
#include "train/algorithms.hpp"
#include "train/checkpoint.hpp"
#include "train/progress_svg.hpp"
#include "train/run_files.hpp"
#include "train/run_policy.hpp"
#include "train/run_state.hpp"

namespace atacom {

namespace fs = std::filesystem;

namespace {

std::string hex(uint64_t h) {
  char b[20];
  std::snprintf(b, sizeof(b), "%016llx", static_cast<unsigned long long>(h));
  return b;
}

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char b[32];
  if (s < 60) std::snprintf(b, sizeof(b), "%.0fs", s);
  else if (s < 3600) std::snprintf(b, sizeof(b), "%dm%02ds", int(s) / 60, int(s) % 60);
  else std::snprintf(b, sizeof(b), "%dh%02dm", int(s) / 3600, (int(s) % 3600) / 60);
  return b;
}

class Run {
 public:
  Run(const RunConfig& cfg, const TrainOptions& opts);
  TrainSummary go();

 private:
  bool violated(const EnvBuffers& b, int i) const {
    const int k = spec_.num_constraints;
    for (int r = 0; r < k; ++r)
      if (b.constraints[size_t(i) * k + r] > spec_.constraint_tolerance[size_t(r)]) return true;
    return false;
  }
  void start_files();
  bool resume_from_checkpoint();  // false: nothing to resume, start at step 0
  void step();
  EvalResult evaluate_now();
  void record(const EvalResult& ev);
  double train_cost() const;
  void save_checkpoint();
  void write_policy(const std::string& file);
  void print_progress(bool force, const EvalResult* ev);
  nlohmann::json summary_json(const EvalResult& ev) const;
  TrainSummary finish(const EvalResult& last);
  uint64_t config_hash() const;
  double wall() const {
    return st_.counters.wall_s + std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  double eval_wall() const { return st_.counters.eval_wall_s + eval_s_; }
  bool stop_here() const { return cfg_.train.stop_at_target && st_.counters.target_met(); }
  std::string path(const char* name) const { return (fs::path(opts_.out_dir) / name).string(); }

  RunConfig cfg_;
  TrainOptions opts_;
  const Algorithm* algo_;
  std::unique_ptr<BatchEnv> env_, eval_env_;  // env_: training batch (learning algorithms only)
  EnvSpec spec_;
  int N_ = 0, D_ = 0, A_ = 0, ninfo_ = 0;
  std::unique_ptr<Learner> learner_;
  std::unique_ptr<Policy> fixed_;  // the action source of algorithms that do not learn
  Policy* policy_ = nullptr;
  RunState st_;
  ProgressFile progress_;
  std::vector<double> actions_;    // (N x A)
  std::chrono::steady_clock::time_point start_, last_print_;
  double eval_s_ = 0;              // wall time this process spent evaluating (excluded from steps/s)
  int64_t steps_at_start_ = 0;
  // The ETA's rate is measured from the first step with learner updates on:
  // warm-up steps (random actions, no updates) run many times faster and
  // would make it far too short. Unset (-1) until then.
  int64_t eta_steps0_ = -1;
  std::chrono::steady_clock::time_point eta_t0_;
  double last_eval_return_ = kNaN;
  int64_t last_ckpt_steps_ = -1;   // env_steps of the newest checkpoint written by this process
  bool stopped_ = false;           // the run ended at the quality target before its budget (train.stop_at_target)
};

Run::Run(const RunConfig& cfg, const TrainOptions& opts) : cfg_(cfg), opts_(opts), algo_(&find_algorithm(cfg.train.algo)) {
  const TrainConfig& t = cfg_.train;
  eval_env_ = make_env(EnvRequest{t.env, t.eval_episodes, algo_->safety, cfg_.env, cfg_.safety});
  spec_ = eval_env_->spec();
  D_ = spec_.obs_dim;
  A_ = spec_.act_dim;
  ninfo_ = static_cast<int>(spec_.info_names.size());
  if (D_ < 1 || A_ < 1) throw std::invalid_argument("env '" + t.env + "' reports empty observation or action space");
  if (spec_.info_reduce.size() != spec_.info_names.size())
    throw std::invalid_argument("env '" + t.env + "' spec: info_reduce and info_names differ in length");
  std::vector<std::string> learner_cols;
  switch (algo_->source) {
    case ActionSource::Learner: {
      N_ = t.num_envs;
      env_ = make_env(EnvRequest{t.env, N_, algo_->safety, cfg_.env, cfg_.safety});
      env_->seed(uint64_t(t.seed));
      LearnerContext ctx{&env_->spec(), N_, uint64_t(t.seed), &env_->buffers(), &cfg_.learner_sections};
      learner_ = learner_entry(algo_->learner).make(ctx, cfg_.learner);
      policy_ = &learner_->policy();
      learner_cols = learner_->progress_columns();
      init_run_state(st_, t, spec_, env_->buffers());
      actions_.assign(size_t(N_) * A_, 0.0);
      break;
    }
    case ActionSource::Attractor: fixed_ = make_attractor_policy(t.env, cfg_.env); break;
    case ActionSource::Random: fixed_ = make_random_policy(D_, A_); break;
    case ActionSource::Zero: fixed_ = make_zero_policy(D_, A_); break;
  }
  if (fixed_) {
    policy_ = fixed_.get();
    st_.train_info_sums.assign(size_t(ninfo_), 0.0);
    if (policy_->obs_dim() != D_ || policy_->act_dim() != A_)
      throw std::invalid_argument("the " + policy_->kind() + " policy does not fit env '" + t.env + "'");
  }
  progress_ = ProgressFile(path("progress.csv"), progress_columns(spec_, learner_cols), target_columns());
}

uint64_t Run::config_hash() const {
  nlohmann::json j = run_config_json(cfg_);
  j["train"].erase("steps");   // a resumed run may extend its budget
  j["train"].erase("preset");  // every value it gave is explicit (and runs from before presets resume)
  j["train"].erase("stop_at_target");  // or stop at the target (where it ends, not how it trains)
  j.erase("host");            // and continue on another machine
  j["env"] = env_config_fingerprint_form(j["env"]);  // runs of builds before a newer env key resume
  const std::string s = j.dump();
  return bin::fnv1a(s.data(), s.size());
}

void Run::step() {
  const TrainConfig& t = cfg_.train;
  policy_->act(st_.obs.data(), N_, false, st_.act_rngs.data(), actions_.data());
  env_->step(actions_.data());
  const EnvBuffers& b = env_->buffers();
  for (int i = 0; i < N_; ++i) {
    bool ok = std::isfinite(b.reward[size_t(i)]) && std::isfinite(b.cost[size_t(i)]);
    for (int j = 0; j < D_; ++j)
      ok = ok && std::isfinite(b.obs[size_t(i) * D_ + j]) && std::isfinite(b.final_obs[size_t(i) * D_ + j]);
    if (!ok)
      throw std::runtime_error("env '" + t.env + "' returned a non-finite observation, reward or cost (env " +
                               std::to_string(i) + ", env step " + std::to_string(st_.counters.env_steps) + ")");
  }
  learner_->observe(st_.obs.data(), actions_.data(), b);
  RunCounters& c = st_.counters;
  const int k = spec_.num_constraints;
  for (int i = 0; i < N_; ++i) {
    for (int col = 0; col < ninfo_; ++col)
      if (spec_.info_reduce[size_t(col)] == InfoReduce::Sum)
        st_.train_info_sums[size_t(col)] += b.info[size_t(i) * ninfo_ + col];
    c.train_violations += violated(b, i);
    if (st_.train_cost >= 0) st_.train_cost += b.cost[size_t(i)] != 0.0f;
    for (int r = 0; r < k; ++r) {
      const double v = b.constraints[size_t(i) * k + r];
      if (std::isfinite(v)) c.train_max_constraint = std::max(c.train_max_constraint, v);
    }
    if (b.done(i)) {
      ++c.train_episodes;
      if (b.terminated[size_t(i)]) ++c.train_terminations;
      if (st_.train_episode_steps >= 0) st_.train_episode_steps += b.episode_length[size_t(i)];
      c.recent_return_sum += b.episode_return[size_t(i)];
      ++c.recent_returns;
      c.last_train_return = b.episode_return[size_t(i)];
    }
  }
  std::copy(b.obs.begin(), b.obs.end(), st_.obs.begin());
  c.env_steps += N_;
}

EvalResult Run::evaluate_now() {
  const auto t0 = std::chrono::steady_clock::now();
  const TrainConfig& t = cfg_.train;
  EvalResult r = evaluate(*eval_env_, *policy_, t.eval_episodes, uint64_t(t.seed), t.eval_deterministic);
  eval_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// One progress row; the best evaluation's policy when it improves.
void Run::record(const EvalResult& ev) {
  RunCounters& c = st_.counters;
  const double train_ret = c.recent_returns > 0 ? c.recent_return_sum / double(c.recent_returns) : c.last_train_return;
  const double now = wall();
  // The first evaluation that meets the env's quality target.
  if (!c.target_met() && meets_target(spec_.target, ev)) {
    c.target_env_steps = c.env_steps;
    c.target_updates = learner_ ? learner_->updates() : 0;
    c.target_wall_s = now;
    c.target_train_cost = train_cost();
  }
  std::vector<double> row = {double(c.env_steps), learner_ ? double(learner_->updates()) : 0.0, now,
                             ev.return_mean, ev.return_std, train_ret};
  if (learner_) {
    const std::vector<double> lv = learner_->progress_values();
    row.insert(row.end(), lv.begin(), lv.end());
  }
  row.insert(row.end(), ev.info.begin(), ev.info.end());
  for (double v : {double(ev.early_terminations), ev.avg_episode_steps, ev.violations, ev.cost_mean,
                   ev.discounted_return_mean, ev.discounted_return_std, ev.max_constraint, ev.episode_max_constraint,
                   double(c.train_episodes), double(c.train_terminations), double(c.train_violations),
                   st_.train_cost >= 0 ? double(st_.train_cost) : kNaN})
    row.push_back(v);
  for (int col = 0; col < ninfo_; ++col)
    if (spec_.info_reduce[size_t(col)] == InfoReduce::Sum) row.push_back(st_.train_info_sums[size_t(col)]);
  for (double v : {c.target_wall_s, c.target_met() ? double(c.target_env_steps) : kNaN,
                   c.target_met() ? double(c.target_updates) : kNaN, c.target_train_cost})
    row.push_back(v);
  progress_.append(row);
  c.progress_rows = progress_.rows();
  c.recent_returns = 0;
  c.recent_return_sum = 0;
  last_eval_return_ = ev.return_mean;
  const TrainConfig& t = cfg_.train;
  write_file_atomic(path("progress.svg"), progress_svg(t.env + " / " + t.algo + " / seed " + std::to_string(t.seed),
                                                      progress_, spec_.num_constraints > 0));
  // The best evaluation by the learner's score (the env's return without a
  // learner; the first of equals; NaN never wins).
  const double score = learner_ ? learner_->best_score(ev) : ev.return_mean;
  const nlohmann::json& prev = st_.best.is_null() ? nlohmann::json() : st_.best["score"];
  const bool better = st_.best.is_null() || (std::isfinite(score) && (!prev.is_number() || score > prev.get<double>()));
  if (better) {
    st_.best = eval_json(ev);
    st_.best["env_steps"] = c.env_steps;
    st_.best["score"] = jnum(score);
    if (learner_) write_policy(run_policy_file(RunPolicy::Best));
  }
}

// Training collisions (the env's every-contact column, InfoRole::AnyContact)
// plus the steps with a constraint row above its tolerance, so far.
double Run::train_cost() const {
  const int col = spec_.column_with(InfoRole::AnyContact);
  const double collisions = col >= 0 ? st_.train_info_sums[size_t(col)] : 0.0;
  return collisions + double(st_.counters.train_violations);
}

void Run::write_policy(const std::string& file) {
  const TrainConfig& t = cfg_.train;
  write_policy_file(path(file.c_str()), *policy_,
                    {{"learner", algo_->learner}, {"env", t.env}, {"algo", t.algo}, {"seed", t.seed},
                     {"env_steps", st_.counters.env_steps}, {"eval_return_mean", jnum(last_eval_return_)},
                     {"config_hash", hex(config_hash())}});
}

void Run::save_checkpoint() {
  const double wall_before = st_.counters.wall_s, eval_before = st_.counters.eval_wall_s;
  st_.counters.eval_wall_s = eval_wall();
  st_.counters.wall_s = wall();  // the checkpoint holds the time so far
  Checkpoint ck;
  ck.payload = save_run_payload(st_, *learner_, *env_);
  const RunCounters& c = st_.counters;
  ck.manifest = {{"format", "atacom-checkpoint"}, {"version", kCheckpointVersion},
                 {"env", cfg_.train.env}, {"algo", cfg_.train.algo}, {"learner", learner_->name()},
                 {"seed", cfg_.train.seed}, {"env_steps", c.env_steps}, {"updates", learner_->updates()},
                 {"wall_s", c.wall_s}, {"progress_rows", c.progress_rows},
                 {"agent_hash", hex(learner_->state_hash())}, {"config_hash", hex(config_hash())},
                 {"payload_sections", {"counters", "learner", "streams", "env"}}};
  const nlohmann::json lm = learner_->manifest();
  for (auto it = lm.begin(); it != lm.end(); ++it) ck.manifest[it.key()] = it.value();
  st_.counters.wall_s = wall_before;
  st_.counters.eval_wall_s = eval_before;
  write_checkpoint_atomic(path("checkpoint.bin"), ck);
  write_file_atomic(path("checkpoint.json"), ck.manifest.dump(2) + "\n");
  last_ckpt_steps_ = st_.counters.env_steps;
}

bool Run::resume_from_checkpoint() {
  const TrainConfig& t = cfg_.train;
  if (!fs::exists(path("checkpoint.bin"))) {
    // Without a checkpoint nothing can continue bitwise: refuse when the run
    // had written results past a checkpoint (checkpoint.json is its trace),
    // restart (and say so) when it had not: rows written before a kill that
    // came ahead of the first checkpoint are rewritten identically.
    int64_t rows = 0;
    std::ifstream f(path("progress.csv"));
    for (std::string line; std::getline(f, line);) ++rows;
    rows = std::max<int64_t>(0, rows - 1);  // the header
    if ((rows > 0 && fs::exists(path("checkpoint.json"))) || fs::exists(path("summary.json")))
      throw std::invalid_argument("checkpoint.bin is missing in '" + opts_.out_dir + "' while progress.csv holds " +
                                  std::to_string(rows) +
                                  " evaluation rows: the run cannot continue bitwise (restore the checkpoint, or "
                                  "start a new run in another directory)");
    if (opts_.log) *opts_.log << "atacom train: no checkpoint in '" << opts_.out_dir << "' yet: starting the run at step 0\n";
    return false;
  }
  const Checkpoint ck = read_checkpoint(path("checkpoint.bin"));
  if (ck.manifest.value("config_hash", "") != hex(config_hash()))
    throw std::runtime_error("checkpoint in '" + opts_.out_dir + "' was written with a different config");
  try {
    load_run_payload(ck.payload, t, spec_, st_, *learner_, *env_);
  } catch (const std::exception& e) {
    throw std::runtime_error("checkpoint in '" + opts_.out_dir + "' cannot be restored: " + e.what());
  }
  const int64_t done = st_.counters.env_steps;
  if (batch_steps(t.steps, N_) < done / N_)
    throw std::invalid_argument("train.steps = " + std::to_string(t.steps) + " is below the " + std::to_string(done) +
                                " env steps the run in '" + opts_.out_dir + "' has done (a budget can only grow)");
  try {
    progress_.restore(st_.counters.progress_rows);
  } catch (const std::exception& e) {
    throw std::runtime_error("cannot resume the run in '" + opts_.out_dir + "': " + e.what());
  }
  // last_eval_return_ stays NaN: the CSV holds it to 9 digits only, and a
  // policy file written with that rounded value would differ from the
  // uninterrupted run's. Every policy file is written after an evaluation
  // of this process (record, or the re-evaluation of a finished run in go()).
  // A kill between checkpoint.bin and checkpoint.json leaves the manifest of
  // the previous checkpoint: rewrite it from the one that was loaded.
  write_file_atomic(path("checkpoint.json"), ck.manifest.dump(2) + "\n");
  last_ckpt_steps_ = done;
  return true;
}

void Run::print_progress(bool force, const EvalResult* ev) {
  if (!opts_.log) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && (!opts_.log_is_tty || now - last_print_ < std::chrono::milliseconds(250))) return;
  last_print_ = now;
  const TrainConfig& t = cfg_.train;
  const RunCounters& c = st_.counters;
  const double el = std::chrono::duration<double>(now - start_).count() - eval_s_;
  const double sps = el > 0 ? double(c.env_steps - steps_at_start_) / el : 0.0;
  // ETA: the remaining steps at the rate since updates began (evaluations
  // included, as they will recur); during warm-up it is not known yet.
  const bool warming = learner_ && eta_steps0_ < 0;
  const double since = std::chrono::duration<double>(now - eta_t0_).count();
  const double rate = eta_steps0_ >= 0 && since > 0 ? double(c.env_steps - eta_steps0_) / since : 0.0;
  const std::string eta = warming ? std::string("after warm-up")
                                  : rate > 0 ? duration_text(double(t.steps - c.env_steps) / rate) : std::string("?");
  char b[320];
  if (!learner_ && ev)
    std::snprintf(b, sizeof(b), "%s/%s seed %lld: %d evaluation episodes: return %s  final distance %s  "
                  "early terminations %d  violations %s per episode", t.env.c_str(), t.algo.c_str(),
                  static_cast<long long>(t.seed), ev->episodes, ProgressFile::format(ev->return_mean).c_str(),
                  ProgressFile::format(ev->final_distance).c_str(), ev->early_terminations,
                  ProgressFile::format(ev->violations).c_str());
  else
  std::snprintf(b, sizeof(b),
                "%s/%s seed %lld: %lld/%lld steps  %.0f steps/s  ETA %s  last return %s  eval %s  violations %lld",
                t.env.c_str(), t.algo.c_str(), static_cast<long long>(t.seed), static_cast<long long>(c.env_steps),
                static_cast<long long>(t.steps), sps, eta.c_str(),
                ProgressFile::format(c.last_train_return).c_str(),
                ProgressFile::format(ev ? ev->return_mean : last_eval_return_).c_str(),
                static_cast<long long>(c.train_violations));
  if (opts_.log_is_tty) *opts_.log << "\r\033[K" << b << std::flush;
  else *opts_.log << b << "\n" << std::flush;
}

nlohmann::json Run::summary_json(const EvalResult& ev) const {
  const TrainConfig& t = cfg_.train;
  const RunCounters& c = st_.counters;
  nlohmann::json s = eval_json(ev);
  s["env"] = t.env;
  s["algo"] = t.algo;
  s["seed"] = t.seed;
  s["safety"] = safety_layer_name(algo_->safety);
  s["learner"] = algo_->learns() ? nlohmann::json(algo_->learner) : nlohmann::json(nullptr);
  s["eval_deterministic"] = t.eval_deterministic;
  s["env_steps"] = c.env_steps;
  s["updates"] = learner_ ? learner_->updates() : 0;
  const double w = wall();
  s["wall_s"] = w;
  // The evaluations' share of the wall time (evaluation runs inside the budget's wall time).
  s["eval_wall_s"] = eval_wall();
  s["eval_share"] = w > 0 ? nlohmann::json(eval_wall() / w) : nlohmann::json(nullptr);
  // The quality target and the first evaluation that met it (null: never).
  s["target"] = target_json(spec_.target);
  s["time_to_target_s"] = jnum(c.target_wall_s);
  s["steps_to_target"] = c.target_met() ? nlohmann::json(c.target_env_steps) : nlohmann::json(nullptr);
  s["updates_to_target"] = c.target_met() ? nlohmann::json(c.target_updates) : nlohmann::json(nullptr);
  s["train_cost_to_target"] = jnum(c.target_train_cost);
  s["stopped_at_target"] = stopped_;
  s["train_episodes"] = c.train_episodes;
  s["train_terminations"] = c.train_terminations;
  s["train_violations"] = c.train_violations;
  // Algorithms that do not learn take no training step: 0, like the other train_* counters.
  s["train_cost"] = st_.train_cost >= 0 ? nlohmann::json(st_.train_cost) : nlohmann::json(nullptr);
  // The paper's "average episode steps over training"; an algorithm that
  // does not learn runs only its evaluation episodes, so theirs stands in.
  if (!learner_) s["train_avg_episode_steps"] = jnum(ev.avg_episode_steps);
  else if (c.train_episodes > 0 && st_.train_episode_steps >= 0)
    s["train_avg_episode_steps"] = double(st_.train_episode_steps) / double(c.train_episodes);
  else s["train_avg_episode_steps"] = nullptr;  // no finished episode yet, or resumed from an older checkpoint
  s["train_max_constraint"] = std::isfinite(c.train_max_constraint) ? nlohmann::json(c.train_max_constraint) : nullptr;
  for (int col = 0; col < ninfo_; ++col) {
    if (spec_.info_reduce[size_t(col)] != InfoReduce::Sum) continue;
    const std::string& name = spec_.info_names[size_t(col)];
    s["train_" + name] = jnum(st_.train_info_sums[size_t(col)]);
    // Collision counts also under the plural names: train_collisions, ...
    const std::string total = event_total_name(name, spec_.role(size_t(col)));
    if (!total.empty()) s["train_" + total] = jnum(st_.train_info_sums[size_t(col)]);
  }
  if (learner_) {
    const nlohmann::json ls = learner_->summary();
    for (auto it = ls.begin(); it != ls.end(); ++it) s[it.key()] = it.value();
  }
  s["agent_hash"] = learner_ ? nlohmann::json(hex(learner_->state_hash())) : nlohmann::json(nullptr);
  s["best"] = st_.best;
  s["policy_final"] = learner_ ? nlohmann::json(run_policy_file(RunPolicy::Final)) : nlohmann::json(nullptr);
  s["policy_best"] = learner_ && !st_.best.is_null() ? nlohmann::json(run_policy_file(RunPolicy::Best))
                                                     : nlohmann::json(nullptr);
  s["host"] = cfg_.host;
  return s;
}

TrainSummary Run::finish(const EvalResult& last) {
  TrainSummary out;
  out.final_eval = last;
  out.env_steps = st_.counters.env_steps;
  out.updates = learner_ ? learner_->updates() : 0;
  out.wall_s = wall();
  out.stopped_at_target = stopped_;
  out.agent_hash = learner_ ? learner_->state_hash() : 0;
  out.summary = summary_json(last);
  return out;
}

// config.json first: a run killed before its first checkpoint is then
// continued by `atacom train --resume` (which starts it at step 0).
void Run::start_files() {
  fs::create_directories(opts_.out_dir);
  write_file_atomic(path("config.json"), run_config_json(cfg_).dump(2) + "\n");
  progress_.start();
}

TrainSummary Run::go() {
  const TrainConfig& t = cfg_.train;
  cfg_.host = host_info();
  start_ = last_print_ = std::chrono::steady_clock::now();
  if (!learner_) {
    // Nothing to train: one evaluation, the same files and keys as a learner's run.
    start_files();
    const EvalResult ev = evaluate_now();
    record(ev);
    print_progress(true, &ev);
    if (opts_.log && opts_.log_is_tty) *opts_.log << "\n";
    TrainSummary out = finish(ev);
    write_file_atomic(path("summary.json"), out.summary.dump(2) + "\n");
    return out;
  }
  const bool resumed = opts_.resume && resume_from_checkpoint();
  if (resumed) write_file_atomic(path("config.json"), run_config_json(cfg_).dump(2) + "\n");  // a grown budget
  else start_files();
  start_ = last_print_ = std::chrono::steady_clock::now();
  steps_at_start_ = st_.counters.env_steps;
  RunCounters& c = st_.counters;
  EvalResult last;
  bool have_eval = false;
  while (c.env_steps < t.steps) {
    if (stop_here()) {  // resumed a run that had stopped at its target
      stopped_ = true;
      break;
    }
    step();
    if (eta_steps0_ < 0 && learner_->updates() > 0) {  // warm-up over: the ETA's rate starts here
      eta_steps0_ = c.env_steps;
      eta_t0_ = std::chrono::steady_clock::now();
    }
    bool end = c.env_steps >= t.steps;
    const bool stop = (opts_.stop_after > 0 && c.env_steps >= opts_.stop_after) ||
                      (opts_.stop_signal && *opts_.stop_signal != 0);
    if (c.env_steps >= c.next_eval || end) {
      while (c.next_eval <= c.env_steps) c.next_eval += t.eval_every;
      last = evaluate_now();
      have_eval = true;
      record(last);
      print_progress(true, &last);
      if (!end && stop_here()) {  // the run ends here: checkpoint and files as at its budget
        end = stopped_ = true;
        if (opts_.log)
          *opts_.log << (opts_.log_is_tty ? "\n" : "") << "atacom train: quality target met at " << c.env_steps
                     << " env steps: the run stops here (train.stop_at_target)\n";
      }
      if (t.checkpoint_every == 0) save_checkpoint();
    } else {
      print_progress(false, nullptr);
    }
    if (t.checkpoint_every > 0 && (c.env_steps >= c.next_ckpt || end)) {
      while (c.next_ckpt <= c.env_steps) c.next_ckpt += t.checkpoint_every;
      save_checkpoint();
    }
    if (stop && !end) {
      if (last_ckpt_steps_ != c.env_steps) save_checkpoint();
      break;
    }
    if (stopped_) break;
  }
  if (opts_.log && opts_.log_is_tty) *opts_.log << "\n";
  if (!have_eval) {  // resumed a finished run, or stopped early
    // The same policy, env seeds and episodes as the evaluation that ended
    // the run: bitwise its result, for summary.json and policy_final.
    last = evaluate_now();
    last_eval_return_ = last.return_mean;
  }
  TrainSummary out = finish(last);
  if (c.env_steps >= t.steps || stopped_) {
    write_policy(run_policy_file(RunPolicy::Final));
    write_file_atomic(path("summary.json"), out.summary.dump(2) + "\n");
  }
  return out;
}
}  // namespace

TrainSummary run_training(const RunConfig& cfg, const TrainOptions& opts) {
  if (opts.out_dir.empty()) throw std::invalid_argument("training needs an output directory");
  const fs::path dir(opts.out_dir);
  if (fs::exists(dir) && !fs::is_directory(dir))
    throw std::invalid_argument("output path '" + opts.out_dir + "' exists and is not a directory");
  // Temp files a killed earlier process of this run left behind: gone first,
  // so a run killed before its first file is complete starts again as new.
  remove_stale_temp_files(opts.out_dir);
  if (opts.resume) {
    if (!fs::exists(dir))
      throw std::invalid_argument("--resume: run directory '" + opts.out_dir + "' does not exist");
    if (!fs::exists(dir / "config.json"))
      throw std::invalid_argument("--resume: '" + opts.out_dir +
                                  "' holds no config.json, so there is no run to resume (start one without --resume)");
  } else if (fs::exists(dir) && !fs::is_empty(dir)) {
    throw std::invalid_argument("output directory '" + opts.out_dir +
                                "' is not empty; pass --resume to continue that run or choose a new directory");
  }
  Run run(cfg, opts);  // builds envs and agent: config errors surface here, before any file is written
  return run.go();
}
}  // namespace atacom
