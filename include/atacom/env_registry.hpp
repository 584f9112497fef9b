// Environments by name. Every env config is a JSON object with one default
// factory (default_env_config) and strict parsing: unknown keys and bad values
// are rejected with a message naming them.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/policy.hpp"

namespace atacom {

struct EnvEntry {
  std::string name;
  std::string help;
  bool has_constraints = false;  // a ControlAffineEnv: every safety layer can wrap it
  nlohmann::json (*default_config)();
  // The plain env; make_env() (atacom/make_env.hpp) adds the safety layer.
  std::unique_ptr<BatchEnv> (*make)(const nlohmann::json& resolved_config, int num_envs);
  // Optional: the family's linear attractor for a resolved config (raw
  // observations in, the env's normalised action out; nullptr: none).
  // Through a safety layer it is LA-ATACOM / LA-SafeLayer.
  std::unique_ptr<Policy> (*make_attractor)(const nlohmann::json& resolved_config) = nullptr;
};

// All registered envs (envs/registry.cpp lists them).
const std::vector<EnvEntry>& env_entries();
std::vector<std::string> env_names();
// Throws std::invalid_argument for an unknown name (listing the known ones).
const EnvEntry& env_entry(const std::string& name);
// Default config, merged with overrides; unknown keys throw std::invalid_argument.
nlohmann::json resolve_env_config(const std::string& name, const nlohmann::json& overrides);

// A resolved env config as fingerprints see it (the trainer's config hash,
// the env snapshots'): keys added after runs were written are left out while
// they hold the value those runs had implicitly, so checkpoints and snapshots
// of earlier builds still load. envs/registry.cpp lists the keys, one line each.
nlohmann::json env_config_fingerprint_form(nlohmann::json config);

// Merge `overrides` into `base` recursively; every key of overrides must exist
// in base (path named in the error), and JSON types must agree (numbers mix).
nlohmann::json merge_config_strict(const nlohmann::json& base, const nlohmann::json& overrides,
                                   const std::string& path = "");

}  // namespace atacom
