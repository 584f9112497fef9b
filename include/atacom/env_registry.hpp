// Environments by name. Every env config is a JSON object with one default
// factory (default_env_config) and strict parsing: unknown keys and bad values
// are rejected with a message naming them.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"

namespace atacom {

struct EnvRequest {
  std::string name;                                   // "pendulum", "table", "shelf", "nav", ...
  int num_envs = 1;                                   // N
  bool atacom = false;                                // wrap in SafeEnv (ATACOM between agent and env)
  nlohmann::json config = nlohmann::json::object();   // overrides of default_env_config(name)
};

struct EnvEntry {
  std::string name;
  std::string help;
  bool supports_atacom = false;
  nlohmann::json (*default_config)();
  std::unique_ptr<BatchEnv> (*make)(const nlohmann::json& resolved_config, int num_envs, bool atacom);
  // Optional per-env SAC settings for an algo ("sac" or "atacom-sac"): a JSON
  // object of SacConfig keys laid over default_sac_config() before a run
  // config's own "sac" section (nullptr: the global defaults).
  nlohmann::json (*default_sac)(const std::string& algo) = nullptr;
};

// All registered envs (envs/registry.cpp lists them).
const std::vector<EnvEntry>& env_entries();
std::vector<std::string> env_names();
// Throws std::invalid_argument for an unknown name (listing the known ones).
const EnvEntry& env_entry(const std::string& name);
// Default config, merged with overrides; unknown keys throw std::invalid_argument.
nlohmann::json resolve_env_config(const std::string& name, const nlohmann::json& overrides);
std::unique_ptr<BatchEnv> make_env(const EnvRequest& request);

// Merge `overrides` into `base` recursively; every key of overrides must exist
// in base (path named in the error), and JSON types must agree (numbers mix).
nlohmann::json merge_config_strict(const nlohmann::json& base, const nlohmann::json& overrides,
                                   const std::string& path = "");

}  // namespace atacom
