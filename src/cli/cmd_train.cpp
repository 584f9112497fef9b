// atacom train: any algorithm of the table on any registered env (logic in train/).
#include <unistd.h>

#include <csignal>
#include <cstdlib>

#include <filesystem>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "cli/json_file.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/limits.hpp"
#include "atacom/env_registry.hpp"
#include "train/algorithms.hpp"
#include "train/presets.hpp"

namespace atacom::cli {
namespace {

volatile int g_checkpoint_signal = 0;
extern "C" void on_checkpoint_signal(int) { g_checkpoint_signal = 1; }

struct TrainArgs {
  std::string env, algo, config, out, sdf, preset;
  int64_t seed = 0, steps = 0;
  int envs = 0, eval_episodes = 0;
  bool resume = false, stop_at_target = false, print_config = false;
  CLI::Option *o_env = nullptr, *o_algo = nullptr, *o_seed = nullptr, *o_steps = nullptr, *o_envs = nullptr,
              *o_eval = nullptr;
};

// The run's config as the flags, --config and the defaults resolve it (what
// --print-config prints and what the run uses).
RunConfig resolve(const TrainArgs& a) {
  RunConfig rc;
  const std::filesystem::path dir(a.out), saved = dir / "config.json";
  if (a.resume) {
    if (a.out.empty()) throw std::invalid_argument("--resume needs --out DIR (the run to continue)");
    if (!std::filesystem::exists(dir))
      throw std::invalid_argument("--resume: run directory '" + a.out + "' does not exist");
    if (!std::filesystem::exists(saved))
      throw std::invalid_argument("--resume: '" + a.out +
                                  "' holds no config.json, so there is no run to resume (start one without --resume)");
    if (!a.config.empty())
      throw std::invalid_argument("--config cannot be combined with --resume: the run's own config.json is used");
    if (!a.sdf.empty())
      throw std::invalid_argument("--sdf cannot be combined with --resume: the run's own config.json is used");
    if (!a.preset.empty())
      throw std::invalid_argument("--preset cannot be combined with --resume: the run's own config.json is used");
    rc = resolve_run_config(read_json_file(saved.string()));
    auto same = [](const CLI::Option* o, bool equal, const char* flag) {
      if (o && o->count() > 0 && !equal)
        throw std::invalid_argument(std::string(flag) + " differs from the run being resumed (see its config.json)");
    };
    same(a.o_env, a.env == rc.train.env, "--env");
    same(a.o_algo, a.algo == rc.train.algo, "--algo");
    same(a.o_seed, a.seed == rc.train.seed, "--seed");
    same(a.o_envs, a.envs == rc.train.num_envs, "--envs");
    same(a.o_eval, a.eval_episodes == rc.train.eval_episodes, "--eval-episodes");
    if (a.o_steps->count() > 0) rc.train.steps = a.steps;  // a resumed run may extend its budget (never shrink it)
    if (a.stop_at_target) rc.train.stop_at_target = true;  // and may be told to stop at its target
  } else {
    nlohmann::json file = a.config.empty() ? nlohmann::json::object() : read_json_file(a.config);
    if (!file.is_object()) throw std::invalid_argument("config file must hold a JSON object");
    nlohmann::json& t = file["train"];
    if (t.is_null()) t = nlohmann::json::object();
    if (!t.is_object()) throw std::invalid_argument("config section 'train' must be a JSON object");
    // Command-line flags win over the file, the file over the defaults.
    if (a.o_env->count()) t["env"] = a.env;
    if (a.o_algo->count()) t["algo"] = a.algo;
    if (a.o_seed->count()) t["seed"] = a.seed;
    if (a.o_steps->count()) t["steps"] = a.steps;
    if (a.o_envs->count()) t["num_envs"] = a.envs;
    if (a.o_eval->count()) t["eval_episodes"] = a.eval_episodes;
    if (!a.preset.empty()) t["preset"] = a.preset;
    if (a.stop_at_target) t["stop_at_target"] = true;
    if (!a.sdf.empty()) {
      if (!t.contains("env") || !t["env"].is_string())
        throw std::invalid_argument("--sdf needs the env named (--env or train.env in --config)");
      nlohmann::json& e = file["env"];
      if (e.is_null()) e = nlohmann::json::object();
      e.merge_patch(sdf_flag_override(t["env"].get<std::string>(), a.sdf));
    }
    rc = resolve_run_config(file);
  }
  return rc;
}

int run(const TrainArgs& a) {
  const RunConfig rc = resolve(a);
  if (a.print_config) {
    std::cout << run_config_json(rc).dump(2) << std::endl;
    return 0;
  }
  if (a.out.empty()) throw std::invalid_argument("--out is required (the run directory; or --print-config)");
  TrainOptions opts;
  opts.out_dir = a.out;
  opts.resume = a.resume;
  opts.log = &std::cerr;
  opts.log_is_tty = ::isatty(STDERR_FILENO) != 0;
  // SIGUSR1 (Slurm's pre-timeout signal, forwarded by `atacom sweep`):
  // checkpoint and exit 75, to be resumed with --resume.
  opts.stop_signal = &g_checkpoint_signal;
  std::signal(SIGUSR1, on_checkpoint_signal);
  if (const char* k = std::getenv("ATACOM_TEST_KILL_AT_WRITE")) arm_kill_at_write(std::atol(k));  // crash tests
  const TrainSummary s = run_training(rc, opts);
  if (g_checkpoint_signal != 0 && s.env_steps < rc.train.steps && !s.stopped_at_target) {
    std::cerr << "atacom train: SIGUSR1: checkpoint written at " << s.env_steps << " env steps; continue with --resume\n";
    return 75;
  }
  std::cout << s.summary.dump() << std::endl;
  return 0;
}

std::string join_names(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string algo_help() {
  return "algorithm, an action source x a safety layer: " + join_names(algorithm_names()) +
         "; la, random, zero and their variants evaluate only (train.algo)";
}

std::string train_footer() {
  return "\nWhat a run writes (DIR/progress.csv columns, DIR/summary.json keys):\n"
         "  cost (info[\"cost\"], per step): max(0, max_i c_i), the largest constraint value, 0 when every row\n"
         "    is satisfied (c_i <= 0 is safe).\n"
         "  eval_max_constraint: the largest constraint value of any step of the evaluation's episodes.\n"
         "  eval_episode_max_constraint: each episode's largest constraint value, averaged over the episodes.\n"
         "  violations: steps per episode with a row above its tolerance; train_violations: the running total.\n"
         "The full config a run uses: atacom train ... --print-config (docs/training.md lists the keys).";
}

const RegisterCommand register_train{Command{
    "train", "train (or, for hand-coded policies, evaluate) an algorithm on a registered env, with checkpoints and resume",
    [](CLI::App& app) -> std::function<int()> {
      auto a = std::make_shared<TrainArgs>();
      // The defaults shown are the train section's (default_train_config); a --config file's train section
      // overrides them, and these flags override the file.
      const TrainConfig d = default_train_config();
      a->env = d.env;
      a->algo = d.algo;
      a->seed = d.seed;
      a->steps = d.steps;
      a->envs = d.num_envs;
      a->eval_episodes = d.eval_episodes;
      a->o_env = app.add_option("--env", a->env, "env: " + join_names(env_names()) + " (train.env)");
      a->o_algo = app.add_option("--algo", a->algo, algo_help());
      a->o_seed = add_integer_flag(app, "--seed", a->seed, seed_range<int64_t>(), "random seed (train.seed)");
      a->o_steps = add_integer_flag(app, "--steps", a->steps, range::closed<int64_t>(1, limits::kMaxSteps),
                                    "env transitions to train for, all envs together (train.steps); evaluation "
                                    "every train.eval_every steps: 1000 under 50k steps, else 10000, unless set");
      a->o_envs = add_integer_flag(app, "--envs", a->envs, range::closed(1, limits::kMaxEnvs),
                                   "parallel training envs N (train.num_envs)");
      a->o_eval = add_integer_flag(app, "--eval-episodes", a->eval_episodes, range::closed(1, limits::kMaxEvalEpisodes),
                                   "episodes per evaluation (train.eval_episodes)");
      app.add_option("--config", a->config, "JSON file with env/<learner>/<layer>/train sections overriding the "
                                            "preset (see --print-config for every key)");
      std::string presets;
      for (const std::string& p : preset_names()) presets += (presets.empty() ? "" : " | ") + p;
      app.add_option("--preset", a->preset,
                     presets + ": per env x algorithm settings under the config file's (train.preset; default " +
                         kDefaultPreset + ", the paper's protocol; configs/presets/)")
          ->check(CLI::IsMember(preset_names()));
      app.add_option("--sdf", a->sdf, "analytic | learned: the distance fields of every object with a shipped model")
          ->check(CLI::IsMember({"analytic", "learned"}));
      app.add_option("--out", a->out, "run directory (must be empty unless --resume); required unless --print-config");
      app.add_flag("--resume", a->resume, "continue the run in --out from its last checkpoint");
      app.add_flag("--stop-at-target", a->stop_at_target,
                   "end the run at the first evaluation that meets the env's quality target (train.stop_at_target)");
      app.add_flag("--print-config", a->print_config,
                   "print the resolved config (every key of every section, defaults filled in: what config.json "
                   "will hold) and exit");
      app.footer(train_footer());
      return [a]() { return run(*a); };
    }}};

}  // namespace
}  // namespace atacom::cli
