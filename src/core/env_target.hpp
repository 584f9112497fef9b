// The quality target's config keys, shared by every env that declares one
// (EnvTarget in atacom/env.hpp):
//   "target_distance": m, in [0, 1000]: an evaluation meets the target when
//                      its mean final_distance is at most this
//   "target_zero_info": info columns that must average 0 over the evaluation
//                      episodes (HRI-Sim: ["spill"])
// An env without a final_distance column declares no target and has neither key.
#pragma once
#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

// Reads both keys (required) from an env section.
EnvTarget read_env_target(ConfigReader& r);
// Adds both keys to an env section.
void write_env_target(nlohmann::json& j, const EnvTarget& t);
// Throws std::invalid_argument naming the key when the spec's target does not
// fit its info columns (a zero_info name that is not a column; a distance
// without a final_distance column).
void check_env_target(const EnvSpec& spec);

}  // namespace atacom
