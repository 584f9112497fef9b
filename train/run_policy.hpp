// Policy files of a run directory (policy_final.bin, policy_best.bin): the
// checkpoint container (train/checkpoint.hpp: tagged, sized, checksummed,
// written atomically) with manifest {"format": "atacom-policy", "kind",
// "learner", "env", "algo", "seed", "env_steps", "obs_dim", "act_dim",
// "config_hash", ...} and the policy's save() bytes as payload.
#pragma once
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/policy.hpp"

namespace atacom {

void write_policy_file(const std::string& path, const Policy& policy, nlohmann::json manifest);

}  // namespace atacom
