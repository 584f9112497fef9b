#include "atacom/env_registry.hpp"

#include <algorithm>
#include <stdexcept>

#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/nav/nav_attractor.hpp"
#include "envs/nav/nav_env.hpp"
#include "envs/pendulum/pendulum.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

// Each env adds one line here (a function declared next to its class).
const std::vector<EnvEntry>& env_entries() {
  static const std::vector<EnvEntry> entries = {
      {"table", "TableEnv: TIAGo++ arm reaching above a table (34 constraints)", true, table_env_default_config,
       make_table_env, make_table_attractor},
      {"shelf", "ShelfEnvSim: TIAGo++ arm reaching into a shelf (34 constraints)", true, shelf_env_default_config,
       make_shelf_env, make_shelf_attractor},
      {"nav", "differential-drive TIAGo to a goal among walls and a moving Fetch (Box2D)", true,
       &nav_default_config_json, &make_nav_env, make_nav_attractor},
      {"hri", "HRI-Sim: TIAGo++ arm carrying a cup past a moving human, spills counted (43 constraints)", true,
       hri_env_default_config, make_hri_env, make_hri_attractor},
      {"hri-upright", "HRI-Sim plus a cup-upright constraint row (ours; 44 constraints)", true,
       hri_upright_env_default_config, make_hri_env, make_hri_attractor},
      pendulum_env_entry(),
  };
  return entries;
}

std::vector<std::string> env_names() {
  std::vector<std::string> names;
  for (const auto& e : env_entries()) names.push_back(e.name);
  return names;
}

const EnvEntry& env_entry(const std::string& name) {
  for (const auto& e : env_entries())
    if (e.name == name) return e;
  std::string known;
  for (const auto& e : env_entries()) known += (known.empty() ? "" : ", ") + e.name;
  throw std::invalid_argument("unknown env '" + printable_text(name) + "' (known: " + known + ")");
}

nlohmann::json env_config_fingerprint_form(nlohmann::json config) {
  struct AddedKey {
    const char* section;
    const char* key;
    bool implicit;  // the value the runs before the key had
  };
  static constexpr AddedKey kAdded[] = {
      {"hri", "spill_cost", false},  // 2026-12-05: the spill as a cost event
  };
  for (const AddedKey& a : kAdded) {
    if (!config.contains(a.section) || !config[a.section].is_object()) continue;
    nlohmann::json& section = config[a.section];
    const auto it = section.find(a.key);
    if (it != section.end() && *it == a.implicit) section.erase(it);
  }
  return config;
}

nlohmann::json merge_config_strict(const nlohmann::json& base, const nlohmann::json& overrides,
                                   const std::string& path) {
  if (!overrides.is_object())
    throw std::invalid_argument("config" + (path.empty() ? std::string() : " key '" + path + "'") +
                                " must be a JSON object");
  nlohmann::json out = base;
  for (auto it = overrides.begin(); it != overrides.end(); ++it) {
    const std::string key = path.empty() ? it.key() : path + "." + it.key();
    if (!base.contains(it.key())) {
      std::vector<std::string> valid;
      for (auto b = base.begin(); b != base.end(); ++b) valid.push_back(b.key());
      throw std::invalid_argument(unknown_key_message(key, path.empty() ? "config" : path, valid));
    }
    const auto& b = base[it.key()];
    const auto& v = it.value();
    if (b.is_object()) {
      out[it.key()] = merge_config_strict(b, v, key);
    } else {
      const bool both_numbers = b.is_number() && v.is_number();
      const bool same = b.type() == v.type() || both_numbers || b.is_null();
      if (!same)
        throw std::invalid_argument("config key '" + key + "' has type " + v.type_name() + ", expected " +
                                    b.type_name());
      if (b.is_number_integer() && v.is_number_float())
        throw std::invalid_argument("config key '" + key + "' must be an integer");
      out[it.key()] = v;
    }
  }
  return out;
}

nlohmann::json resolve_env_config(const std::string& name, const nlohmann::json& overrides) {
  // Runs recorded before issue 30 named today's hri-upright "hri" (envs/arm/arm_registry.cpp).
  const nlohmann::json& o = name == "hri" ? hri_upgrade_pre_issue30_config(overrides) : overrides;
  return merge_config_strict(env_entry(name).default_config(), o, "env");
}

std::unique_ptr<Policy> make_attractor_policy(const std::string& env, const nlohmann::json& resolved_env_config) {
  const EnvEntry& e = env_entry(env);
  if (e.make_attractor == nullptr) {
    std::string with;
    for (const auto& x : env_entries())
      if (x.make_attractor) with += (with.empty() ? "" : ", ") + x.name;
    throw std::invalid_argument("env '" + env + "' has no linear attractor (envs with one: " + with + ")");
  }
  return e.make_attractor(resolved_env_config);
}

}  // namespace atacom
