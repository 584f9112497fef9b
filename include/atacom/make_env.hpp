// An env batch by name behind a safety layer: the registry's env
// (atacom/env_registry.hpp) wrapped by a layer of the table
// (atacom/safety_layer.hpp). Every front end builds its envs here.
#pragma once
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/safety_layer.hpp"

namespace atacom {

struct EnvRequest {
  std::string name;                                   // "pendulum", "table", "shelf", "nav", ...
  int num_envs = 1;                                   // N
  SafetyLayer safety = SafetyLayer::None;             // wrapper between the action source and the env
  nlohmann::json config = nlohmann::json::object();   // overrides of default_env_config(name)
  nlohmann::json safety_params = nullptr;             // the layer's section (null: its defaults for the env)
};

// Throws std::invalid_argument for unknown names, bad configs, a layer on an
// env without constraints, or a batch larger than this machine's memory.
std::unique_ptr<BatchEnv> make_env(const EnvRequest& request);

}  // namespace atacom
