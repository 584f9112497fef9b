#include "atacom/safety_layer.hpp"

#include <stdexcept>

#include "atacom/safe_env.hpp"
#include "src/core/config_json.hpp"
#include "src/safety/safe_layer_env.hpp"

namespace atacom {

const char* safety_layer_name(SafetyLayer s) {
  switch (s) {
    case SafetyLayer::None: return "none";
    case SafetyLayer::Atacom: return "atacom";
    case SafetyLayer::SafeLayer: return "safelayer";
  }
  return "?";
}

const char* safety_layer_title(SafetyLayer s) {
  switch (s) {
    case SafetyLayer::None: return "no";
    case SafetyLayer::Atacom: return "ATACOM";
    case SafetyLayer::SafeLayer: return "SafeLayer";
  }
  return "?";
}

std::vector<std::string> safety_layer_names() { return {"none", "atacom", "safelayer"}; }

SafetyLayer parse_safety_layer(const std::string& name) {
  for (SafetyLayer s : {SafetyLayer::None, SafetyLayer::Atacom, SafetyLayer::SafeLayer})
    if (name == safety_layer_name(s)) return s;
  throw std::invalid_argument("unknown safety layer '" + printable_text(name) + "' (known: none, atacom, safelayer)");
}

std::unique_ptr<BatchEnv> wrap_safety(std::unique_ptr<BatchEnv> env, SafetyLayer layer) {
  if (layer == SafetyLayer::None) return env;
  auto* ca = dynamic_cast<ControlAffineEnv*>(env.get());
  if (ca == nullptr)
    throw std::invalid_argument("env '" + env->spec().name + "' has no constraint model, so the " +
                                safety_layer_title(layer) + " safety layer cannot wrap it");
  std::unique_ptr<ControlAffineEnv> inner(ca);
  env.release();
  switch (layer) {
    case SafetyLayer::Atacom: {
      const ProjectorModel pm = inner->projector_model();
      return std::make_unique<SafeEnv>(std::move(inner), pm);
    }
    case SafetyLayer::SafeLayer: {
      // Linearised over the env's own control period, thresholds from the env.
      const SafeLayerModel sm = safelayer_model(inner->projector_model(), inner->spec().dt, inner->safelayer_threshold());
      return std::make_unique<SafeLayerEnv>(std::move(inner), sm);
    }
    case SafetyLayer::None: break;
  }
  return inner;
}

}  // namespace atacom
