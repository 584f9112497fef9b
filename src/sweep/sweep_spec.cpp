#include "src/sweep/sweep_spec.hpp"

#include <set>
#include <stdexcept>

#include "atacom/learner.hpp"
#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "train/algorithms.hpp"
#include "train/presets.hpp"

namespace atacom {

std::string SweepCell::name() const { return env + "-" + algo + "-seed" + std::to_string(seed); }
std::string SweepCell::run_dir() const { return "runs/" + env + "/" + algo + "/seed-" + std::to_string(seed); }

namespace {

std::vector<std::string> name_list(ConfigReader& r, const char* key) {
  const nlohmann::json& x = r.at(key);
  const std::string what = "sweep spec key '" + std::string(key) + "'";
  if (!x.is_array() || x.empty()) throw std::invalid_argument(what + " must be a non-empty list of names");
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (const auto& e : x) {
    if (!e.is_string() || e.get<std::string>().empty()) throw std::invalid_argument(what + " must hold non-empty strings");
    if (!seen.insert(e.get<std::string>()).second)
      throw std::invalid_argument(what + " lists '" + printable_text(e.get<std::string>()) + "' twice");
    out.push_back(e.get<std::string>());
  }
  return out;
}

bool listed(const std::vector<std::string>& v, const std::string& s) {
  for (const auto& x : v)
    if (x == s) return true;
  return false;
}

}  // namespace

SweepSpec parse_sweep_spec(const nlohmann::json& j) {
  if (!j.is_object()) throw std::invalid_argument("sweep spec must be a JSON object");
  ConfigReader r(j, "sweep");
  SweepSpec s;
  s.envs = name_list(r, "envs");
  s.algos = name_list(r, "algos");
  for (const auto& a : s.algos) {
    try {
      find_algorithm(a);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("sweep spec key 'algos': " + std::string(e.what()));
    }
  }
  const nlohmann::json& seeds = r.at("seeds");
  if (!seeds.is_array() || seeds.empty() || seeds.size() > 100000)
    throw std::invalid_argument("sweep spec key 'seeds' must be a list of 1 to 100000 integers >= 0");
  std::set<int64_t> seen;
  for (size_t i = 0; i < seeds.size(); ++i) {
    const int64_t v = checked_number<int64_t>(seeds[i], "sweep spec key 'seeds[" + std::to_string(i) + "]'",
                                              range::at_least<int64_t>(0));
    if (!seen.insert(v).second) throw std::invalid_argument("sweep spec key 'seeds' lists " + std::to_string(v) + " twice");
    s.seeds.push_back(v);
  }
  s.steps = r.integer<int64_t>("steps", range::closed<int64_t>(1, limits::kMaxSteps));
  r.get("num_envs", s.num_envs, range::closed(1, limits::kMaxEnvs));
  r.get("preset", s.preset);
  if (!s.preset.empty()) {
    try {
      find_preset(s.preset);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("sweep spec key 'preset': " + std::string(e.what()));
    }
  }
  r.get("description", s.description);
  if (const nlohmann::json* o = r.sub("overrides")) {
    if (!o->is_object()) throw std::invalid_argument("sweep spec key 'overrides' must be a JSON object");
    for (auto it = o->begin(); it != o->end(); ++it) {
      const std::string& k = it.key();
      const size_t slash = k.find('/');
      const std::string what = "sweep spec key 'overrides." + printable_text(k) + "'";
      if (slash == std::string::npos || k.find('/', slash + 1) != std::string::npos)
        throw std::invalid_argument(what + ": the key must be '<env>/<algo>' (either part may be '*')");
      const std::string env = k.substr(0, slash), algo = k.substr(slash + 1);
      if (env != "*" && !listed(s.envs, env))
        throw std::invalid_argument(what + ": env '" + printable_text(env) + "' is not in 'envs'");
      if (algo != "*" && !listed(s.algos, algo))
        throw std::invalid_argument(what + ": algo '" + printable_text(algo) + "' is not in 'algos'");
      if (!it.value().is_object()) throw std::invalid_argument(what + " must be a JSON object (a run config fragment)");
      if (const auto t = it.value().find("train"); t != it.value().end() && t->is_object())
        for (const char* fixed : {"env", "algo", "seed", "steps", "num_envs", "preset"})
          if (t->contains(fixed))
            throw std::invalid_argument(what + ": train." + fixed + " is set by the sweep spec, not by an override");
    }
    s.overrides = *o;
  }
  r.finish();
  // Resolve every cell now: a bad override or an algo/env pair that cannot run fails here, naming the cell.
  for (const SweepCell& c : sweep_cells(s)) {
    try {
      resolve_run_config(c.config);
    } catch (const std::exception& e) {
      throw std::invalid_argument("sweep cell " + printable_text(c.name()) + ": " + e.what());
    }
  }
  return s;
}

nlohmann::json sweep_spec_json(const SweepSpec& s) {
  nlohmann::json j = {{"envs", s.envs}, {"algos", s.algos}, {"seeds", s.seeds}, {"steps", s.steps}};
  if (s.num_envs > 0) j["num_envs"] = s.num_envs;
  if (!s.preset.empty()) j["preset"] = s.preset;
  if (!s.overrides.empty()) j["overrides"] = s.overrides;
  if (!s.description.empty()) j["description"] = s.description;
  return j;
}

std::vector<SweepCell> sweep_cells(const SweepSpec& s) {
  std::vector<SweepCell> out;
  for (const auto& env : s.envs)
    for (const auto& algo : s.algos) {
      const Algorithm& a = find_algorithm(algo);
      const nlohmann::json base = config_fragment(s.overrides, env, algo);
      for (int64_t seed : s.seeds) {
        SweepCell c;
        c.env = env;
        c.algo = algo;
        c.seed = seed;
        c.steps = s.steps;
        c.learns = a.learns();
        c.config = base;
        nlohmann::json& t = c.config["train"];
        if (t.is_null()) t = nlohmann::json::object();
        t["env"] = env;
        t["algo"] = algo;
        t["seed"] = seed;
        t["steps"] = s.steps;
        if (s.num_envs > 0) t["num_envs"] = s.num_envs;
        if (!s.preset.empty()) t["preset"] = s.preset;
        out.push_back(std::move(c));
      }
    }
  return out;
}

Shard parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  auto bad = [&]() -> Shard {
    throw std::invalid_argument("--shard '" + printable_text(text) + "': must be i/n with 0 <= i < n (e.g. 0/4)");
  };
  if (slash == std::string::npos || slash == 0 || slash + 1 >= text.size()) return bad();
  Shard s;
  try {
    size_t p1 = 0, p2 = 0;
    s.index = std::stoi(text.substr(0, slash), &p1);
    s.count = std::stoi(text.substr(slash + 1), &p2);
    if (p1 != slash || p2 != text.size() - slash - 1) return bad();
  } catch (const std::exception&) {
    return bad();
  }
  if (s.count < 1 || s.index < 0 || s.index >= s.count) return bad();
  return s;
}

}  // namespace atacom
