// The safety-layer table: one line per layer. A new layer is its wrapper
// file (a wrap function beside its LayeredEnv) plus one line here; the
// algorithm table then names every action source under it.
#include "atacom/safety_layer.hpp"

#include <stdexcept>

#include "atacom/control_affine_env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/safe_env.hpp"
#include "src/core/config_json.hpp"
#include "src/safety/cbf_env.hpp"
#include "src/safety/safe_layer_env.hpp"

namespace atacom {

namespace {
nlohmann::json no_params(const std::string&) { return nlohmann::json::object(); }
}  // namespace

const std::vector<SafetyLayerEntry>& safety_layer_entries() {
  static const std::vector<SafetyLayerEntry> entries = {
      {"none", "no", "the env as it is", no_params, nullptr},
      {"atacom", "ATACOM", "the action acts on the constraint manifold's tangent space (the paper's method)", no_params,
       wrap_atacom},
      {"safelayer", "SafeLayer", "Dalal et al.'s correction of the action on the analytic rows (docs/safelayer.md)",
       no_params, wrap_safelayer},
      {"cbf", "CBF", "the control-barrier-function QP: no row approaches its boundary faster than gamma c (src/safety/cbf_env.hpp)",
       cbf_default_params, wrap_cbf},
  };
  return entries;
}

std::vector<SafetyLayer> safety_layers() {
  std::vector<SafetyLayer> out;
  for (size_t i = 0; i < safety_layer_entries().size(); ++i) out.push_back(SafetyLayer::parse(safety_layer_entries()[i].name));
  return out;
}

std::vector<std::string> safety_layer_names() {
  std::vector<std::string> out;
  for (const SafetyLayerEntry& e : safety_layer_entries()) out.push_back(e.name);
  return out;
}

SafetyLayer SafetyLayer::parse(const std::string& name) {
  const auto& t = safety_layer_entries();
  for (size_t i = 0; i < t.size(); ++i)
    if (t[i].name == name) return SafetyLayer(static_cast<uint8_t>(i));
  std::string known;
  for (const SafetyLayerEntry& e : t) known += (known.empty() ? "" : ", ") + e.name;
  throw std::invalid_argument("unknown safety layer '" + printable_text(name) + "' (known: " + known + ")");
}

nlohmann::json resolve_safety_params(SafetyLayer layer, const std::string& env, const nlohmann::json& overrides) {
  const nlohmann::json defaults = layer.entry().default_params(env);
  if (overrides.is_null()) return defaults;
  if (!overrides.is_object())
    throw std::invalid_argument("config section '" + layer.name() + "' must be a JSON object");
  return merge_config_strict(defaults, overrides, layer.name());
}

std::unique_ptr<BatchEnv> wrap_safety(std::unique_ptr<BatchEnv> env, SafetyLayer layer, const nlohmann::json& params) {
  if (layer.is_none()) return env;
  auto* ca = dynamic_cast<ControlAffineEnv*>(env.get());
  if (ca == nullptr)
    throw std::invalid_argument("env '" + env->spec().name + "' has no constraint model, so the " + layer.title() +
                                " safety layer cannot wrap it");
  const std::string env_name = env->spec().name;
  std::unique_ptr<ControlAffineEnv> inner(ca);
  env.release();
  return layer.entry().wrap(std::move(inner), params.is_null() ? resolve_safety_params(layer, env_name, params) : params);
}

}  // namespace atacom
