#include "train/presets.hpp"

#include <stdexcept>

#include "atacom/learner.hpp"
#include "atacom/safety_layer.hpp"
#include "atacom_presets.hpp"  // generated: kPresetFiles {name, text}
#include "src/core/config_json.hpp"
#include "train/algorithms.hpp"

namespace atacom {

void merge_into(nlohmann::json& a, const nlohmann::json& b) {
  for (auto it = b.begin(); it != b.end(); ++it) {
    if (it.value().is_object() && a.contains(it.key()) && a[it.key()].is_object()) merge_into(a[it.key()], it.value());
    else a[it.key()] = it.value();
  }
}

nlohmann::json config_fragment(const nlohmann::json& entries, const std::string& env, const std::string& algo) {
  const Algorithm& a = find_algorithm(algo);
  nlohmann::json out = nlohmann::json::object();
  for (const std::string& key : {std::string("*/*"), env + "/*", "*/" + algo, env + "/" + algo}) {
    if (!entries.contains(key)) continue;
    nlohmann::json o = entries.at(key);
    o.erase("note");
    if (key.find('*') != std::string::npos) {
      // Learner sections reach the cells whose learner reads them (the SAC
      // family's "sac" reaches sac-lag cells too).
      const LearnerEntry* own = a.learns() ? &learner_entry(a.learner) : nullptr;
      for (const LearnerEntry& le : learner_entries()) {
        if (!(own && own->owns(le.section))) o.erase(le.section);
        for (const LearnerSection& x : le.extra_sections)
          if (!(own && own->owns(x.name))) o.erase(x.name);
      }
      for (const SafetyLayerEntry& l : safety_layer_entries())
        if (l.name != a.safety.name()) o.erase(l.name);
    }
    merge_into(out, o);
  }
  return out;
}

namespace {

Preset parse_preset(const char* name, const char* text) {
  auto bad = [&](const std::string& what) -> Preset {
    throw std::logic_error(std::string("configs/presets/") + name + ".json: " + what);
  };
  nlohmann::json j;
  try {
    j = parse_json_strict(text, std::string("preset ") + name);
  } catch (const std::exception& e) {
    return bad(e.what());
  }
  if (!j.is_object() || !j.contains("entries") || !j["entries"].is_object()) return bad("needs an object 'entries'");
  Preset p{name, j.value("description", ""), j["entries"]};
  for (auto it = p.entries.begin(); it != p.entries.end(); ++it) {
    if (!it.value().is_object()) bad("entry '" + it.key() + "' must be an object");
    if (!it.value().contains("note") || !it.value()["note"].is_string())
      bad("entry '" + it.key() + "' needs a \"note\": where its values come from");
    if (it.key().find('/') == std::string::npos) bad("entry key '" + it.key() + "' is not <env>/<algo>");
  }
  return p;
}

}  // namespace

const std::vector<Preset>& presets() {
  static const std::vector<Preset> all = [] {
    std::vector<Preset> v;
    for (const auto& [name, text] : kPresetFiles) v.push_back(parse_preset(name, text));
    return v;
  }();
  return all;
}

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const Preset& p : presets()) out.push_back(p.name);
  return out;
}

const Preset& find_preset(const std::string& name) {
  for (const Preset& p : presets())
    if (p.name == name) return p;
  std::string known;
  for (const Preset& p : presets()) known += (known.empty() ? "" : ", ") + p.name;
  throw std::invalid_argument("unknown preset '" + printable_text(name) + "' (known: " + known + ")");
}

}  // namespace atacom
