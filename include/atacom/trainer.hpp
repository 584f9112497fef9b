// Training runs: any registered env, any algorithm of the table
// (train/algorithms.hpp: an action source x a safety layer), with
// evaluation, progress files, checkpoints and bitwise resume. The loop knows
// the learner and policy contracts only (atacom/learner.hpp, policy.hpp).
//
// A run directory holds
//   config.json      the full resolved config {"env", "<learner section>", "train", "host"}
//   progress.csv     one row per evaluation (columns: progress_columns())
//   progress.svg     eval return vs env steps, redrawn after every evaluation
//   summary.json     final evaluation, run-wide training counters, the best
//                    evaluation ("best"), the first evaluation that met the
//                    env's quality target (time_to_target_s, steps_to_target,
//                    updates_to_target, train_cost_to_target; null: never),
//                    the evaluation's share of wall time, the policy files, the host
//   checkpoint.bin   checkpoint (train/checkpoint.hpp); checkpoint.json its manifest
//   policy_final.bin the policy at the end of training   (learning algorithms only)
//   policy_best.bin  the policy of the best evaluation (Learner::best_score: SAC's eval return)
// env_steps counts transitions over all N envs. Evaluation uses its own env
// batch and RNG streams (atacom/evaluate.hpp), so it never changes the
// training trajectory. Algorithms without a learner (la, random, zero and
// their safety-layer variants) train nothing: the run is one evaluation
// (one progress row at env_steps 0, every train_* counter 0) with the same
// files and keys, no checkpoint and no policy files.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/evaluate.hpp"
#include "atacom/policy.hpp"
#include "atacom/safety_layer.hpp"

namespace atacom {

struct TrainConfig {
  std::string env = "pendulum";   // registered env name
  std::string algo = "sac";       // an algorithm of the table (train/algorithms.hpp)
  int64_t seed = 0;
  int64_t steps = 100000;         // env transitions, all envs together (learning algorithms)
  int num_envs = 1;               // N parallel training envs
  int64_t eval_every = 10000;     // env steps between evaluations (and at the end); a config that does
                                  // not set it gets default_eval_every(steps)
  int eval_episodes = 10;         // run in parallel, one env each
  bool eval_deterministic = true; // mean action (true) or sampled (false)
  int64_t checkpoint_every = 0;   // env steps between checkpoints; 0: at every evaluation
  std::string preset = "paper";   // learner preset (train/presets.hpp) the other sections were laid over
  // End the run at the first evaluation that meets the env's quality target
  // (EnvSpec::target; summary.json then says "stopped_at_target": true).
  // Not part of the checkpoint's config hash: it moves where a run ends, not its trajectory.
  bool stop_at_target = false;
};
// The one default factory.
TrainConfig default_train_config();
// train.eval_every when a config leaves it out: 1000 for runs under 50k env
// steps (a 20k run gets a 20-point curve instead of 2), else 10000, the
// paper's interval (200 points over its 2M-step runs).
int64_t default_eval_every(int64_t steps);
void to_json(nlohmann::json& j, const TrainConfig& c);
void from_json(const nlohmann::json& j, TrainConfig& c);  // unknown keys and bad values rejected

struct RunConfig {
  TrainConfig train;
  nlohmann::json env;      // the env's resolved config (defaults + overrides)
  nlohmann::json learner;  // the learner's resolved section (null: the algorithm does not learn)
  nlohmann::json learner_sections = nlohmann::json::object();  // its further sections, resolved ({"lagrangian": ...})
  nlohmann::json safety;   // the safety layer's resolved parameters (an object; empty for layers without any)
  nlohmann::json host;     // where the run was computed: recorded, never read (null until a run writes it)
};
// Resolve a config file's content ({"env"?, "<learner section>"?, "<layer
// section>"?, "train"?, "host"?}; anything else is rejected). Lowest to
// highest: the defaults (env, learner, layer, train), the fragment of the
// preset train.preset for (train.env, train.algo) (train/presets.hpp), the
// file's sections. A learner section of another learner, one given to an
// algorithm without a learner, or a section of another safety layer is an
// error. "host" is accepted and kept as it is (so DIR/config.json re-runs a
// run anywhere; its preset then changes nothing, every key being explicit).
RunConfig resolve_run_config(const nlohmann::json& file, const TrainConfig* train_base = nullptr);
nlohmann::json run_config_json(const RunConfig& c);
// The safety layer of the run's algorithm.
SafetyLayer run_safety_layer(const RunConfig& c);

struct TrainOptions {
  std::string out_dir;            // required
  bool resume = false;
  std::ostream* log = nullptr;    // progress line target (nullptr: silent)
  bool log_is_tty = false;        // rewrite the line in place
  // Stop (after writing a checkpoint) once env_steps reaches this; 0 = never.
  // Lets tests stop a run exactly where a kill would have left its checkpoint.
  int64_t stop_after = 0;
  // Set (to non-zero) by a signal handler: the run writes a checkpoint after
  // the current batch step and returns early (Slurm's pre-timeout signal).
  const volatile int* stop_signal = nullptr;
};

struct TrainSummary {
  EvalResult final_eval;
  int64_t env_steps = 0, updates = 0;
  double wall_s = 0;
  bool stopped_at_target = false; // ended at the first evaluation that met the target (train.stop_at_target)
  uint64_t agent_hash = 0;        // the learner's state_hash() at the end (0 without a learner)
  nlohmann::json summary;         // what summary.json holds
};

// Runs (or resumes) training into opts.out_dir. Throws std::invalid_argument
// on bad configs or an unusable directory, before doing any work.
// Resuming needs the directory with its config.json; a checkpoint.bin that
// is gone while progress.csv holds evaluations is refused (the run cannot
// continue bitwise); with no evaluation yet the run restarts from step 0
// and says so on the log. A budget below the steps already done is refused.
TrainSummary run_training(const RunConfig& cfg, const TrainOptions& opts);

// A run directory's learned policy: policy_final.bin (the end of training)
// or policy_best.bin (the best evaluation), for any learner, acting exactly
// as in the run's evaluations. For `atacom rollout/shelf-real --policy
// trained --run DIR` and deployment.
enum class RunPolicy : uint8_t { Final = 0, Best = 1 };
const char* run_policy_file(RunPolicy which);  // "policy_final.bin", "policy_best.bin"

class TrainedPolicy final : public Policy {
 public:
  // Throws std::runtime_error naming the problem (no config.json, a run of an
  // algorithm that does not learn, missing or corrupt policy file, a file of
  // another run or env).
  static std::unique_ptr<TrainedPolicy> load(const std::string& run_dir, RunPolicy which = RunPolicy::Final);

  int obs_dim() const override { return inner_->obs_dim(); }
  int act_dim() const override { return inner_->act_dim(); }
  std::string kind() const override { return inner_->kind(); }
  void act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) override {
    inner_->act(obs, N, deterministic, rngs, actions);
  }
  // The deterministic (mean) action.
  void act(const float* obs, int N, double* actions) { inner_->act(obs, N, true, nullptr, actions); }
  void save(std::ostream& out) const override { inner_->save(out); }
  void load(std::istream& in) override { inner_->load(in); }

  const RunConfig& config() const { return cfg_; }
  SafetyLayer safety() const { return run_safety_layer(cfg_); }  // the layer the run trained through
  const nlohmann::json& manifest() const { return manifest_; }   // the policy file's manifest

 private:
  TrainedPolicy() = default;
  RunConfig cfg_;
  nlohmann::json manifest_;
  std::unique_ptr<Policy> inner_;
};
inline std::unique_ptr<TrainedPolicy> load_run_policy(const std::string& run_dir, RunPolicy which = RunPolicy::Final) {
  return TrainedPolicy::load(run_dir, which);
}

// Column names of progress.csv for an env (spec of the env the run acts in)
// and a learner's columns: env_steps, updates, wall_s, eval_return_mean,
// eval_return_std, train_episode_return, <learner columns>, <info columns>,
// early_terminations, avg_episode_steps, violations, eval_cost_mean,
// eval_discounted_return_mean, eval_discounted_return_std,
// eval_max_constraint, eval_episode_max_constraint, train_episodes,
// train_terminations, train_violations, train_cost,
// train_<info> for every summed info column, time_to_target_s,
// steps_to_target, updates_to_target, train_cost_to_target (the first
// evaluation that met the quality target, at or before this row; empty
// cells until one has). eval_cost_mean: the evaluation episodes' summed step
// cost (EnvBuffers::cost), averaged; train_cost: the step cost summed over
// every training step so far.
std::vector<std::string> progress_columns(const EnvSpec& spec, const std::vector<std::string>& learner_columns);

// Hand-written SVG line chart of eval return (mean +- std band) vs env steps.
std::string learning_curve_svg(const std::string& title, const std::vector<double>& steps,
                               const std::vector<double>& mean, const std::vector<double>& std);

}  // namespace atacom
