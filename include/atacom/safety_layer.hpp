// The safety layer between an action source and an env.
//
// A safety layer is an env wrapper: it takes the action source's action in
// [-1, 1]^m and steps the inner env with a safe one, so every action source
// (learner, attractor, random) runs through every layer. The inner env must
// be a ControlAffineEnv (it exposes f, G and its constraint rows).
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "atacom/env.hpp"

namespace atacom {

enum class SafetyLayer : uint8_t {
  None = 0,       // the env as it is
  Atacom = 1,     // SafeEnv: the action acts on the constraint manifold's tangent space
  SafeLayer = 2,  // SafeLayerEnv: Dalal et al.'s correction of the action, with the analytic rows
};

// "none", "atacom", "safelayer".
const char* safety_layer_name(SafetyLayer s);
// "ATACOM", "SafeLayer": for messages.
const char* safety_layer_title(SafetyLayer s);
std::vector<std::string> safety_layer_names();
// Throws std::invalid_argument for an unknown name (listing the known ones).
SafetyLayer parse_safety_layer(const std::string& name);

// Wraps `env` in the layer (None returns it unchanged). Throws
// std::invalid_argument when the env has no constraint model (not a
// ControlAffineEnv) and a layer was asked for.
std::unique_ptr<BatchEnv> wrap_safety(std::unique_ptr<BatchEnv> env, SafetyLayer layer);

}  // namespace atacom
