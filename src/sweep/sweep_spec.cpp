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

nlohmann::json SweepCell::config() const {
  nlohmann::json c = base ? *base : nlohmann::json::object();
  nlohmann::json& t = c["train"];
  if (t.is_null()) t = nlohmann::json::object();
  t["env"] = env;
  t["algo"] = algo;
  t["seed"] = seed;
  t["steps"] = steps;
  if (num_envs > 0) t["num_envs"] = num_envs;
  if (!preset.empty()) t["preset"] = preset;
  return c;
}

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
      for (auto sec = it.value().begin(); sec != it.value().end(); ++sec)
        if (!sec.value().is_object())
          throw std::invalid_argument("sweep spec key 'overrides." + printable_text(k) + "." + printable_text(sec.key()) +
                                      "' must be a JSON object (a config section), not " + value_text(sec.value()));
      if (const auto t = it.value().find("train"); t != it.value().end())
        for (const char* fixed : {"env", "algo", "seed", "steps", "num_envs", "preset"})
          if (t->contains(fixed))
            throw std::invalid_argument(what + ": train." + fixed + " is set by the sweep spec, not by an override");
    }
    s.overrides = *o;
  }
  r.finish();
  const int64_t cells = int64_t(s.envs.size()) * int64_t(s.algos.size()) * int64_t(s.seeds.size());
  if (cells > kMaxSweepCells)
    throw std::invalid_argument("sweep spec has " + std::to_string(s.envs.size()) + " envs x " +
                                std::to_string(s.algos.size()) + " algos x " + std::to_string(s.seeds.size()) +
                                " seeds = " + std::to_string(cells) + " cells, more than the limit of " +
                                std::to_string(kMaxSweepCells) + " (split it into several sweeps)");
  // Resolve every (env, algo) pair now, with its first seed (the seeds differ in
  // train.seed only, already checked): a bad override or a pair that cannot run
  // fails here, naming the cell.
  const std::vector<SweepCell> all = sweep_cells(s);
  for (size_t i = 0; i < all.size(); i += s.seeds.size()) {
    try {
      resolve_run_config(all[i].config());
    } catch (const std::exception& e) {
      throw std::invalid_argument("sweep cell " + printable_text(all[i].name()) + ": " + e.what());
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
  out.reserve(s.envs.size() * s.algos.size() * s.seeds.size());
  for (const auto& env : s.envs)
    for (const auto& algo : s.algos) {
      const Algorithm& a = find_algorithm(algo);
      const auto shared = std::make_shared<const nlohmann::json>(config_fragment(s.overrides, env, algo));
      for (int64_t seed : s.seeds) {
        SweepCell c;
        c.env = env;
        c.algo = algo;
        c.seed = seed;
        c.steps = s.steps;
        c.learns = a.learns();
        c.base = shared;
        c.num_envs = s.num_envs;
        c.preset = s.preset;
        out.push_back(std::move(c));
      }
    }
  return out;
}

Shard parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  const auto bad = [&]() {
    return std::invalid_argument("--shard '" + printable_text(text, 40) +
                                 "': must be i/n with 0 <= i < n, two decimal integers, n at most " +
                                 std::to_string(kMaxSweepCells) + " (e.g. 0/4)");
  };
  if (slash == std::string::npos) throw bad();
  const std::optional<int> i = parse_integer<int>(std::string_view(text).substr(0, slash));
  const std::optional<int> n = parse_integer<int>(std::string_view(text).substr(slash + 1));
  if (!i || !n || *n < 1 || *n > kMaxSweepCells || *i < 0 || *i >= *n) throw bad();
  return Shard{*i, *n};
}

}  // namespace atacom
