// atacom attack: train a SAC adversary (train/adversary.hpp) to reach the
// largest constraint value through a safety layer; prints one JSON object
// like `atacom rollout` and adds it to DIR/summary.json as "attack".
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include "atacom/trainer.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "src/core/fs_util.hpp"
#include "train/adversary.hpp"
#include "train/algorithms.hpp"

namespace atacom::cli {
namespace {

struct AttackArgs {
  std::string env, safety = "atacom", config, out;
  int64_t seed = 0, steps = 50000;
  int envs = 4;
  bool resume = false;
  CLI::Option *o_env = nullptr, *o_safety = nullptr, *o_seed = nullptr, *o_steps = nullptr, *o_envs = nullptr;
};

int run(const AttackArgs& a) {
  RunConfig rc;
  const std::filesystem::path dir(a.out), saved = dir / "config.json";
  const std::string algo = algorithm_for(ActionSource::Learner, "adversary", parse_safety_layer(a.safety)).name;
  if (a.resume) {
    if (!std::filesystem::exists(saved))
      throw std::invalid_argument("--resume: '" + a.out + "' holds no config.json, so there is no attack to resume");
    if (!a.config.empty()) throw std::invalid_argument("--config cannot be combined with --resume");
    rc = resolve_run_config(read_json_file(saved.string()));
    auto same = [](const CLI::Option* o, bool equal, const char* flag) {
      if (o->count() > 0 && !equal) throw std::invalid_argument(std::string(flag) + " differs from the attack being resumed");
    };
    same(a.o_env, a.env == rc.train.env, "--env");
    same(a.o_safety, algo == rc.train.algo, "--safety");
    same(a.o_seed, a.seed == rc.train.seed, "--seed");
    same(a.o_envs, a.envs == rc.train.num_envs, "--envs");
    if (find_algorithm(rc.train.algo).learner != "adversary")
      throw std::invalid_argument("'" + a.out + "' holds a run of '" + rc.train.algo + "', not an attack");
    if (a.o_steps->count()) rc.train.steps = a.steps;
  } else {
    if (a.env.empty()) throw std::invalid_argument("--env is required");
    nlohmann::json file = a.config.empty() ? nlohmann::json::object() : read_json_file(a.config);
    if (!file.is_object()) throw std::invalid_argument("config file must hold a JSON object");
    nlohmann::json& t = file["train"];
    if (t.is_null()) t = nlohmann::json::object();
    if (!t.is_object()) throw std::invalid_argument("config section 'train' must be a JSON object");
    // An attack's defaults: 4 envs, a short evaluation every 10k steps.
    if (!t.contains("eval_every")) t["eval_every"] = 10000;
    if (!t.contains("eval_episodes")) t["eval_episodes"] = 2;
    if (!t.contains("num_envs") || a.o_envs->count()) t["num_envs"] = a.envs;
    if (!t.contains("steps") || a.o_steps->count()) t["steps"] = a.steps;
    if (t.contains("algo") && t["algo"] != algo)
      throw std::invalid_argument("the config's train.algo is not the attack's (" + algo + ")");
    t["env"] = a.env;
    t["algo"] = algo;
    if (a.o_seed->count()) t["seed"] = a.seed;
    rc = resolve_run_config(file);
  }
  TrainOptions opts;
  opts.out_dir = a.out;
  opts.resume = a.resume;
  opts.log = &std::cerr;
  opts.log_is_tty = ::isatty(STDERR_FILENO) != 0;
  TrainSummary s = run_training(rc, opts);
  nlohmann::json out = attack_result(s.summary);
  s.summary["attack"] = out;
  write_file_atomic((dir / "summary.json").string(), s.summary.dump(2) + "\n");
  std::cout << out.dump() << std::endl;
  return 0;
}

const RegisterCommand register_attack{Command{
    "attack", "train a SAC adversary to break a safety layer: largest constraint value, violations, collisions",
    [](CLI::App& app) -> std::function<int()> {
      auto a = std::make_shared<AttackArgs>();
      a->o_env = app.add_option("--env", a->env, "env name (one with constraints: table, shelf, nav)");
      a->o_safety = app.add_option("--safety", a->safety, "the layer under attack: " + safety_choices())
                        ->check(CLI::IsMember(atacom::safety_layer_names()));
      a->o_steps = add_integer_flag(app, "--steps", a->steps, range::closed<int64_t>(1, limits::kMaxSteps),
                                    "env steps of the attack (all envs together)");
      a->o_seed = add_integer_flag(app, "--seed", a->seed, seed_range<int64_t>(), "random seed");
      a->o_envs = add_integer_flag(app, "--envs", a->envs, range::closed(1, limits::kMaxEnvs), "parallel envs");
      app.add_option("--config", a->config, "JSON file with env/adversary/train sections overriding the defaults");
      app.add_option("--out", a->out, "run directory (must be empty unless --resume)")->required();
      app.add_flag("--resume", a->resume, "continue the attack in --out from its last checkpoint");
      return [a]() { return run(*a); };
    }}};

}  // namespace
}  // namespace atacom::cli
