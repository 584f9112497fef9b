// Run configuration: the train section, and resolving a config file into
// the env's, the learner's and the trainer's settings.
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "atacom/learner.hpp"
#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "train/algorithms.hpp"
#include "train/presets.hpp"

namespace atacom {

TrainConfig default_train_config() { return TrainConfig{}; }

int64_t default_eval_every(int64_t steps) { return steps < 50000 ? 1000 : 10000; }

void to_json(nlohmann::json& j, const TrainConfig& c) {
  j = nlohmann::json{{"env", c.env}, {"algo", c.algo}, {"seed", c.seed}, {"steps", c.steps},
                     {"num_envs", c.num_envs}, {"eval_every", c.eval_every}, {"eval_episodes", c.eval_episodes},
                     {"eval_deterministic", c.eval_deterministic}, {"checkpoint_every", c.checkpoint_every},
                     {"preset", c.preset},
                     {"stop_at_target", c.stop_at_target}};
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
  r.get("preset", c.preset);
  r.get("stop_at_target", c.stop_at_target);
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
  try {
    find_preset(c.preset);
  } catch (const std::invalid_argument& e) {
    bad(std::string("preset: ") + e.what());
  }
}

// An object section of the file (nullptr when absent).
const nlohmann::json* object_section(const nlohmann::json* s, const std::string& name) {
  if (s && !s->is_object()) throw std::invalid_argument("config section '" + name + "' must be a JSON object");
  return s;
}
}  // namespace

SafetyLayer run_safety_layer(const RunConfig& c) { return find_algorithm(c.train.algo).safety; }

RunConfig resolve_run_config(const nlohmann::json& file, const TrainConfig* train_base) {
  ConfigReader r(file, "config");
  RunConfig c;
  c.train = train_base ? *train_base : default_train_config();
  const nlohmann::json* t = object_section(r.sub("train"), "train");
  // The preset's fragment for the cell goes under the file: its train keys
  // first (train.env, train.algo and train.preset come from the file alone).
  if (t) {
    for (const char* key : {"env", "algo", "preset"})
      if (t->contains(key) && t->at(key).is_string()) from_json(nlohmann::json{{key, t->at(key)}}, c.train);
  }
  validate(c.train);
  const Algorithm& algo = find_algorithm(c.train.algo);
  nlohmann::json preset = config_fragment(find_preset(c.train.preset).entries, c.train.env, c.train.algo);
  auto from_preset = [&](const std::string& section) -> const nlohmann::json* {
    return preset.contains(section) ? &preset[section] : nullptr;
  };
  try {
    if (const auto* pt = from_preset("train")) from_json(*pt, c.train);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("preset '" + c.train.preset + "': " + e.what());
  }
  if (t) from_json(*t, c.train);
  // Unless the preset or the file sets it: an evaluation every 1000 steps
  // for runs under 50k steps, so a short run has a curve (default_eval_every).
  const bool eval_every_set = (t && t->contains("eval_every")) || (from_preset("train") && from_preset("train")->contains("eval_every"));
  if (!train_base && !eval_every_set) c.train.eval_every = default_eval_every(c.train.steps);
  validate(c.train);
  if (const auto* h = r.sub("host")) c.host = *h;  // a record of where a run was computed: kept, not read
  // Learner sections: the ones the algorithm's own learner reads, and no other.
  const LearnerEntry* own = algo.learns() ? &learner_entry(algo.learner) : nullptr;
  auto check_learner_section = [&](const std::string& name) -> const nlohmann::json* {
    const nlohmann::json* s = object_section(r.sub(name.c_str()), name);
    if ((s || from_preset(name)) && !(own && own->owns(name)))
      throw std::invalid_argument("config section '" + name + "'" + (s ? "" : " of preset '" + c.train.preset + "'") +
                                  " does not apply to algo '" + algo.name + "' (" +
                                  (algo.learns() ? "it trains the '" + algo.learner + "' learner"
                                                 : std::string("it has no learner")) + ")");
    return s;
  };
  const nlohmann::json* section = nullptr;
  for (const LearnerEntry& le : learner_entries()) {
    const nlohmann::json* s = check_learner_section(le.section);
    if (own && le.section == own->section) section = s;
    for (const LearnerSection& x : le.extra_sections) check_learner_section(x.name);
  }
  // Safety-layer sections: the algorithm's own layer's, and no other.
  nlohmann::json layer_overrides = nullptr;
  for (const SafetyLayerEntry& l : safety_layer_entries()) {
    const nlohmann::json* s = object_section(r.sub(l.name.c_str()), l.name);
    if (!s && !from_preset(l.name)) continue;
    if (l.name != algo.safety.name())
      throw std::invalid_argument("config section '" + l.name + "' does not apply to algo '" + algo.name + "' (its safety layer is " +
                                  algo.safety.name() + ")");
    layer_overrides = nlohmann::json::object();
    if (const auto* p = from_preset(l.name)) merge_into(layer_overrides, *p);
    if (s) merge_into(layer_overrides, *s);
  }
  const nlohmann::json* e = object_section(r.sub("env"), "env");
  r.finish();
  if (algo.learns()) {
    const LearnerEntry& le = learner_entry(algo.learner);
    // The learner's defaults, the preset's keys, then the file's (top-level
    // keys replace, so "target_entropy": null still works).
    nlohmann::json merged = le.default_config();
    for (const nlohmann::json* over : {from_preset(le.section), section})
      if (over)
        for (auto it = over->begin(); it != over->end(); ++it) merged[it.key()] = it.value();
    c.learner = le.resolve(merged);
    for (const LearnerSection& x : le.extra_sections) {
      nlohmann::json m = x.default_config();
      for (const nlohmann::json* over : {from_preset(x.name), r.sub(x.name.c_str())})
        if (over)
          for (auto it = over->begin(); it != over->end(); ++it) m[it.key()] = it.value();
      c.learner_sections[x.name] = x.resolve(m);
    }
  }
  nlohmann::json env_overrides = nlohmann::json::object();
  if (const auto* p = from_preset("env")) merge_into(env_overrides, *p);
  if (e) merge_into(env_overrides, *e);
  c.env = resolve_env_config(c.train.env, env_overrides);
  c.safety = resolve_safety_params(algo.safety, c.train.env, layer_overrides);
  return c;
}

nlohmann::json run_config_json(const RunConfig& c) {
  nlohmann::json j = {{"env", c.env}, {"train", c.train}};
  const Algorithm& algo = find_algorithm(c.train.algo);
  if (algo.learns()) j[learner_entry(algo.learner).section] = c.learner;
  for (auto it = c.learner_sections.begin(); it != c.learner_sections.end(); ++it) j[it.key()] = it.value();
  if (c.safety.is_object() && !c.safety.empty()) j[algo.safety.name()] = c.safety;
  if (!c.host.is_null()) j["host"] = c.host;
  return j;
}

}  // namespace atacom
