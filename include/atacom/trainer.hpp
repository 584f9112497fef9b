// Training loop: any registered env, SAC or ATACOM-SAC, with evaluation,
// progress files, checkpoints and bitwise resume.
//
// A run directory holds
//   config.json    the full resolved config {"env": ..., "sac": ..., "train": ...}
//   progress.csv   one row per evaluation (columns in progress_columns())
//   progress.svg   eval return vs env steps, redrawn after every evaluation
//   summary.json   final evaluation + run-wide training counters
//   checkpoint.bin checkpoint (see checkpoint.hpp); checkpoint.json its manifest, for humans
// env_steps counts transitions over all N envs. Updates run at
// updates_per_step per transition; evaluation uses its own env batch and RNG
// streams, so it never changes the training trajectory.
#pragma once
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "train/sac.hpp"

namespace atacom {

struct TrainConfig {
  std::string env = "pendulum";   // registered env name
  std::string algo = "sac";       // "sac" (plain env) or "atacom-sac" (env wrapped in ATACOM)
  int64_t seed = 0;
  int64_t steps = 100000;         // env transitions, all envs together
  int num_envs = 1;               // N parallel training envs
  int64_t eval_every = 10000;     // env steps between evaluations (and at the end)
  int eval_episodes = 10;         // run in parallel, one env each
  bool eval_deterministic = true; // mean action (true) or sampled (false)
  int64_t checkpoint_every = 0;   // env steps between checkpoints; 0: at every evaluation
};
// The one default factory.
TrainConfig default_train_config();
void to_json(nlohmann::json& j, const TrainConfig& c);
void from_json(const nlohmann::json& j, TrainConfig& c);  // unknown keys and bad values rejected

struct RunConfig {
  TrainConfig train;
  SacConfig sac;
  nlohmann::json env;  // the env's resolved config (defaults + overrides)
};
// Resolve a config file's content ({"env"?, "sac"?, "train"?}, each section
// overriding defaults; anything else rejected). env is resolved against
// train.env's defaults, so set train.env before (or inside the file).
RunConfig resolve_run_config(const nlohmann::json& file, const TrainConfig* train_base = nullptr);
nlohmann::json run_config_json(const RunConfig& c);

struct EvalResult {
  double return_mean = 0, return_std = 0;
  int episodes = 0;
  int early_terminations = 0;     // episodes that ended terminated (not truncated)
  double avg_episode_steps = 0;
  double violations = 0;          // steps per episode with a constraint row above its tolerance
  std::vector<double> info;       // per info column: reduced per episode, averaged over episodes
};

struct TrainOptions {
  std::string out_dir;            // required
  bool resume = false;
  std::ostream* log = nullptr;    // progress line target (nullptr: silent)
  bool log_is_tty = false;        // rewrite the line in place
  // Stop (after writing a checkpoint) once env_steps reaches this; 0 = never.
  // Lets tests stop a run exactly where a kill would have left its checkpoint.
  int64_t stop_after = 0;
};

struct TrainSummary {
  EvalResult final_eval;
  int64_t env_steps = 0, updates = 0;
  double wall_s = 0;
  uint64_t agent_hash = 0;        // Sac::state_hash() at the end
  nlohmann::json summary;         // what summary.json holds
};

// Runs (or resumes) training into opts.out_dir. Throws std::invalid_argument
// on bad configs or an unusable directory, before doing any work.
TrainSummary run_training(const RunConfig& cfg, const TrainOptions& opts);

// The policy of a finished (or checkpointed) run, loaded from its directory
// (config.json + checkpoint.bin): the actor with the run's observation
// normalisation, acting with its mean action. For evaluation protocols
// (e.g. `atacom shelf-real --run DIR`) and deployment.
class TrainedPolicy {
 public:
  // Throws std::runtime_error naming the problem (missing files, corrupt or
  // mismatching checkpoint).
  static std::unique_ptr<TrainedPolicy> load(const std::string& run_dir);
  ~TrainedPolicy();
  // obs: (N x obs_dim) raw env observations; actions: (N x act_dim) in [-1, 1].
  void act(const float* obs, int N, double* actions);
  const RunConfig& config() const { return cfg_; }
  int obs_dim() const;
  int act_dim() const;

 private:
  TrainedPolicy() = default;
  struct Impl;
  RunConfig cfg_;
  std::unique_ptr<Impl> impl_;
};

// Column names of progress.csv for an env with these info columns.
std::vector<std::string> progress_columns(const std::vector<std::string>& info_names);

// Hand-written SVG line chart of eval return (mean +- std band) vs env steps.
std::string learning_curve_svg(const std::string& title, const std::vector<double>& steps,
                               const std::vector<double>& mean, const std::vector<double>& std);

}  // namespace atacom
