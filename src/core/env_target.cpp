#include "src/core/env_target.hpp"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace atacom {

namespace {
bool has_column(const EnvSpec& spec, const std::string& name) {
  return std::find(spec.info_names.begin(), spec.info_names.end(), name) != spec.info_names.end();
}
}  // namespace

EnvTarget read_env_target(ConfigReader& r) {
  EnvTarget t;
  t.distance = r.number("target_distance", range::closed(0.0, 1000.0));
  const nlohmann::json& z = r.at("target_zero_info");
  const std::string what = "config key '" + r.path("target_zero_info") + "'";
  if (!z.is_array() || z.size() > 64) throw std::invalid_argument(what + " must be a list of at most 64 info column names");
  std::set<std::string> seen;
  for (const nlohmann::json& x : z) {
    if (!x.is_string() || x.get<std::string>().empty())
      throw std::invalid_argument(what + " must hold non-empty strings (info column names)");
    if (!seen.insert(x.get<std::string>()).second)
      throw std::invalid_argument(what + " lists '" + printable_text(x.get<std::string>()) + "' twice");
    t.zero_info.push_back(x.get<std::string>());
  }
  return t;
}

void write_env_target(nlohmann::json& j, const EnvTarget& t) {
  j["target_distance"] = t.distance;
  j["target_zero_info"] = t.zero_info;
}

void check_env_target(const EnvSpec& spec) {
  const EnvTarget& t = spec.target;
  if (!t.defined()) {
    if (!t.zero_info.empty())
      throw std::invalid_argument("config: env.target_zero_info is set for env '" + spec.name + "', which declares no target distance");
    return;
  }
  if (spec.column_with(InfoRole::GoalDistance) < 0)
    throw std::invalid_argument("config: env.target_distance is set for env '" + spec.name +
                                "', which reports no final_distance");
  for (const std::string& name : t.zero_info) {
    if (has_column(spec, name)) continue;
    std::string cols;
    for (const std::string& c : spec.info_names) cols += (cols.empty() ? "" : ", ") + c;
    throw std::invalid_argument("config: env.target_zero_info: '" + printable_text(name) + "' is not an info column of env '" +
                                spec.name + "' (columns: " + cols + ")");
  }
}

}  // namespace atacom
