// The safety layers between an action source and an env: one table of
// entries (src/safety/safety_layer.cpp), one wrapper file per layer.
//
// A safety layer is an env wrapper: it takes the action source's action in
// [-1, 1]^m and steps the inner env with a safe one, so every action source
// (learner, attractor, random) runs through every layer. The inner env must
// be a ControlAffineEnv (it exposes f, G and its constraint rows). A layer's
// own parameters (none for ATACOM and SafeLayer, whose rows and margins are
// the env's) are a run-config section named after the layer, resolved
// against the entry's per-env defaults; the algorithm table
// (train/algorithms.hpp) names every action source under every layer.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"

namespace atacom {

class ControlAffineEnv;

struct SafetyLayerEntry {
  std::string name;   // "atacom": --safety value, algorithm-name part, config section
  std::string title;  // "ATACOM": for messages and figures
  std::string help;
  // The layer's parameters for an env (a JSON object; empty: the layer has
  // none and writes no config section).
  nlohmann::json (*default_params)(const std::string& env) = nullptr;
  // Wraps `inner` with the resolved parameters. nullptr: the identity (none).
  std::unique_ptr<BatchEnv> (*wrap)(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json& params) = nullptr;
};

// "none" first, then every layer; the order is the order of help texts and tables.
const std::vector<SafetyLayerEntry>& safety_layer_entries();

// A safety layer: a handle on an entry of the table. Default: none.
class SafetyLayer {
 public:
  constexpr SafetyLayer() = default;
  // The layers other code names (the paper's two; a new layer needs none of these).
  static const SafetyLayer None, Atacom, SafeLayer;
  // Throws std::invalid_argument for an unknown name (listing the known ones).
  static SafetyLayer parse(const std::string& name);

  const SafetyLayerEntry& entry() const { return safety_layer_entries()[index_]; }
  const std::string& name() const { return entry().name; }
  const std::string& title() const { return entry().title; }
  bool is_none() const { return index_ == 0; }
  friend constexpr bool operator==(SafetyLayer a, SafetyLayer b) { return a.index_ == b.index_; }
  friend constexpr bool operator!=(SafetyLayer a, SafetyLayer b) { return a.index_ != b.index_; }

 private:
  constexpr explicit SafetyLayer(uint8_t index) : index_(index) {}
  uint8_t index_ = 0;  // into safety_layer_entries()
};
inline constexpr SafetyLayer SafetyLayer::None{0};
inline constexpr SafetyLayer SafetyLayer::Atacom{1};
inline constexpr SafetyLayer SafetyLayer::SafeLayer{2};

// Every layer, in table order (for --safety choices and tests).
std::vector<SafetyLayer> safety_layers();
std::vector<std::string> safety_layer_names();
// "none", "atacom", "safelayer".
inline const char* safety_layer_name(SafetyLayer s) { return s.name().c_str(); }
// "no", "ATACOM", "SafeLayer": for messages.
inline const char* safety_layer_title(SafetyLayer s) { return s.title().c_str(); }
inline SafetyLayer parse_safety_layer(const std::string& name) { return SafetyLayer::parse(name); }

// The layer's resolved parameters for an env: its defaults with `overrides`
// laid over (strict: unknown keys and wrong types name the key). A layer
// without parameters accepts only an empty or absent section.
nlohmann::json resolve_safety_params(SafetyLayer layer, const std::string& env, const nlohmann::json& overrides);

// Wraps `env` in the layer (None returns it unchanged) with the layer's
// resolved parameters (null: its defaults for the env). Throws
// std::invalid_argument when the env has no constraint model (not a
// ControlAffineEnv) and a layer was asked for.
std::unique_ptr<BatchEnv> wrap_safety(std::unique_ptr<BatchEnv> env, SafetyLayer layer,
                                      const nlohmann::json& params = nullptr);

}  // namespace atacom
