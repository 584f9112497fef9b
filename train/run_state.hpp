// The trainer's own state (the learner keeps its own) and the checkpoint
// payload that holds both:
//   "CNTR" counters (since checkpoint version 5 with the evaluation time and
//   the first evaluation that met the quality target) | info sums | best evaluation (JSON text) |
//   "LRNR" learner payload | "STRM" action streams, observations | "ENVS" env batch |
//   "EPST" steps of the finished training episodes (i64; absent in checkpoints
//   of earlier builds, which load with it unknown) |
//   "COST" the training cost so far (i64; absent in checkpoints of earlier
//   builds, which load with it unknown)
// Loading validates every counter against the config (train/run_state.cpp),
// so a checkpoint with a valid checksum but impossible numbers is refused
// with the name of the first bad one instead of spinning or erasing files.
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/learner.hpp"
#include "atacom/rng.hpp"
#include "atacom/trainer.hpp"

namespace atacom {

struct RunCounters {
  int64_t env_steps = 0;
  int64_t next_eval = 0;          // env steps of the next evaluation (a multiple of eval_every)
  int64_t next_ckpt = 0;          // of the next checkpoint (a multiple of checkpoint_every; 0 when it is 0)
  int64_t train_episodes = 0, train_terminations = 0;
  int64_t train_violations = 0;   // env-steps with some constraint row above its tolerance
  double train_max_constraint = -std::numeric_limits<double>::infinity();  // over all training steps and rows
  double wall_s = 0;
  int64_t recent_returns = 0;     // finished training episodes since the last progress row
  double recent_return_sum = 0;
  double last_train_return = std::numeric_limits<double>::quiet_NaN();
  int64_t progress_rows = 0;      // rows of progress.csv
  double eval_wall_s = 0;         // of wall_s, the time spent evaluating
  // The first evaluation that met the env's quality target (-1 and NaN: none yet).
  int64_t target_env_steps = -1, target_updates = -1;
  double target_wall_s = std::numeric_limits<double>::quiet_NaN();
  double target_train_cost = std::numeric_limits<double>::quiet_NaN();  // training collisions + violating steps until then
  bool target_met() const { return target_env_steps >= 0; }

  template <class F>
  void visit(F&& f) {
    f(env_steps); f(next_eval); f(next_ckpt); f(train_episodes); f(train_terminations); f(train_violations);
    f(train_max_constraint); f(wall_s); f(recent_returns); f(recent_return_sum); f(last_train_return);
    f(progress_rows); f(eval_wall_s); f(target_env_steps); f(target_updates); f(target_wall_s); f(target_train_cost);
  }
};

struct RunState {
  RunCounters counters;
  std::vector<double> train_info_sums;  // (n_info) summed over all training steps
  nlohmann::json best;                  // the best evaluation so far (eval_json + "env_steps"), null: none
  std::vector<Rng> act_rngs;            // (N) training action noise, stream (seed, kActStream + i)
  std::vector<float> obs;               // (N x obs_dim) raw observation to act on next
  // Steps of the finished training episodes (their episode_length summed):
  // over train_episodes, the paper's "average episode steps over training".
  // -1: unknown (a run resumed from a checkpoint written before it was kept).
  int64_t train_episode_steps = 0;
  // Steps of training with cost 1 (EnvBuffers::cost summed): summary.json's
  // and progress.csv's train_cost. -1: unknown (resumed from an older checkpoint).
  int64_t train_cost = 0;
};

// Fresh state of a run: counters at step 0, streams keyed by the seed.
void init_run_state(RunState& s, const TrainConfig& t, const EnvSpec& spec, const EnvBuffers& initial);

std::string save_run_payload(const RunState& s, const Learner& learner, const BatchEnv& env);
// Restores all three; throws std::runtime_error naming the first field that
// is truncated, corrupt, or impossible for this config (counters checked
// against train: steps multiple of N, next evaluation and checkpoint where
// the loop puts them, episode and violation counts within the steps, ...).
void load_run_payload(const std::string& payload, const TrainConfig& t, const EnvSpec& spec, RunState& s,
                      Learner& learner, BatchEnv& env);

// Batch steps a budget of `steps` env steps takes with N envs (the last one may overshoot).
inline int64_t batch_steps(int64_t steps, int N) { return (steps + N - 1) / N; }

}  // namespace atacom
