// Run configuration: the train section, and resolving a config file into
// the env's, the learner's and the trainer's settings.
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "atacom/learner.hpp"
#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "train/algorithms.hpp"

namespace atacom {

TrainConfig default_train_config() { return TrainConfig{}; }

int64_t default_eval_every(int64_t steps) { return steps < 50000 ? 1000 : 10000; }

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
  try {
    find_algorithm(c.algo);
  } catch (const std::invalid_argument& e) {
    bad(std::string("algo: ") + e.what());
  }
  if (c.seed < 0) bad("seed must be >= 0");
  if (c.steps < 1 || c.steps > limits::kMaxSteps) bad("steps must be in [1, 10^12]");
  if (c.num_envs < 1 || c.num_envs > (1 << 20)) bad("num_envs must be in [1, 2^20]");
  if (c.eval_every < 1 || c.eval_every > limits::kMaxSteps) bad("eval_every must be in [1, 10^12]");
  if (c.eval_episodes < 1 || c.eval_episodes > 100000) bad("eval_episodes must be in [1, 100000]");
  if (c.checkpoint_every < 0) bad("checkpoint_every must be >= 0");
  env_entry(c.env);  // unknown env names fail here, listing the known ones
}
}  // namespace

SafetyLayer run_safety_layer(const RunConfig& c) { return find_algorithm(c.train.algo).safety; }

RunConfig resolve_run_config(const nlohmann::json& file, const TrainConfig* train_base) {
  ConfigReader r(file, "config");
  RunConfig c;
  c.train = train_base ? *train_base : default_train_config();
  const nlohmann::json* t = r.sub("train");
  if (t) from_json(*t, c.train);
  if (!train_base && !(t && t->is_object() && t->contains("eval_every")))
    c.train.eval_every = default_eval_every(c.train.steps);
  const nlohmann::json* e = r.sub("env");
  if (const auto* h = r.sub("host")) c.host = *h;  // a record of where a run was computed: kept, not read
  validate(c.train);
  const Algorithm& algo = find_algorithm(c.train.algo);
  // Learner sections: the algorithm's own learner's, and no other.
  const nlohmann::json* section = nullptr;
  for (const LearnerEntry& le : learner_entries()) {
    const nlohmann::json* s = r.sub(le.section.c_str());
    if (!s) continue;
    if (le.name != algo.learner)
      throw std::invalid_argument("config section '" + le.section + "' does not apply to algo '" + algo.name + "' (" +
                                  (algo.learns() ? "it trains the '" + algo.learner + "' learner"
                                                 : std::string("it has no learner")) + ")");
    section = s;
  }
  r.finish();
  if (algo.learns()) {
    const LearnerEntry& le = learner_entry(algo.learner);
    // The learner's defaults for this env and layer, then the file's keys
    // (top-level keys replace, so "target_entropy": null still works).
    nlohmann::json merged = le.default_config(c.train.env, algo.safety);
    if (section) {
      if (!section->is_object()) throw std::invalid_argument("config section '" + le.section + "' must be a JSON object");
      for (auto it = section->begin(); it != section->end(); ++it) merged[it.key()] = it.value();
    }
    c.learner = le.resolve(merged);
  }
  c.env = resolve_env_config(c.train.env, e ? *e : nlohmann::json::object());
  return c;
}

nlohmann::json run_config_json(const RunConfig& c) {
  nlohmann::json j = {{"env", c.env}, {"train", c.train}};
  const Algorithm& algo = find_algorithm(c.train.algo);
  if (algo.learns()) j[learner_entry(algo.learner).section] = c.learner;
  if (!c.host.is_null()) j["host"] = c.host;
  return j;
}

}  // namespace atacom
