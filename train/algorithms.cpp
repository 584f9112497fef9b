#include "train/algorithms.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"

#include <stdexcept>
#include <utility>

namespace atacom {

// The action sources, one line each; every one runs under every layer.
const std::vector<ActionSourceEntry>& action_sources() {
  using A = ActionSource;
  static const std::vector<ActionSourceEntry> table = {
      {"sac", A::Learner, "sac", true, "SAC (trains)"},
      {"sac-lag", A::Learner, "sac-lag", true, "SAC-Lagrangian against the episode-cost budget (trains)"},
      {"ppo", A::Learner, "ppo", true, "PPO (trains)"},
      {"ppo-lag", A::Learner, "ppo-lag", true, "PPO-Lagrangian against the episode-cost budget (trains)"},
      {"la", A::Attractor, "", false, "the env's linear attractor (evaluated only)"},
      {"random", A::Random, "", false, "uniform random actions (evaluated only)"},
      {"zero", A::Zero, "", false, "zero actions (evaluated only)"},
      {"attack", A::Learner, "adversary", false, "SAC adversary maximising the constraint values (trains)"},
  };
  return table;
}

const std::vector<Algorithm>& algorithms() {
  static const std::vector<Algorithm> table = [] {
    std::vector<Algorithm> t;
    for (const ActionSourceEntry& src : action_sources())
      for (SafetyLayer layer : safety_layers()) {
        const std::string& l = layer.name();
        const std::string name = layer.is_none() ? src.stem : src.layer_first ? l + "-" + src.stem : src.stem + "-" + l;
        const std::string help = src.help + (layer.is_none() ? std::string() : ", through " + layer.title());
        t.push_back({name, src.source, layer, src.learner, help});
      }
    return t;
  }();
  return table;
}

std::vector<std::string> algorithm_names() {
  std::vector<std::string> names;
  for (const Algorithm& a : algorithms()) names.push_back(a.name);
  return names;
}

const Algorithm& find_algorithm(const std::string& name) {
  for (const Algorithm& a : algorithms())
    if (a.name == name) return a;
  std::string known;
  for (const Algorithm& a : algorithms()) known += (known.empty() ? "" : ", ") + a.name;
  throw std::invalid_argument("unknown algorithm '" + printable_text(name) + "' (known: " + known + ")");
}

std::string algorithm_color(const std::string& algo) {
  // Okabe and Ito (2008): distinguishable with every common colour-vision deficiency.
  static const std::pair<const char*, const char*> fixed[] = {
      {"atacom-sac", "#0072B2"},     // blue: the paper's method
      {"sac", "#D55E00"},            // vermillion
      {"safelayer-sac", "#009E73"},  // bluish green
      {"cbf-sac", "#CC79A7"},        // reddish purple
      {"sac-lag", "#E69F00"},        // orange
      {"la-atacom", "#56B4E9"},      // sky blue
      {"la", "#000000"},             // black
      {"atacom-ppo", "#332288"},     // Tol's muted set from here: indigo
      {"ppo", "#882255"},            // wine
      {"ppo-lag", "#999933"},        // olive
      {"safelayer-ppo", "#117733"},  // green
      {"cbf-ppo", "#AA4499"},        // purple
  };
  for (const auto& [name, color] : fixed)
    if (algo == name) return color;
  static const char* muted[] = {"#44AA99", "#88CCEE", "#DDCC77", "#CC6677", "#332288", "#882255", "#117733", "#999933"};
  const uint64_t h = bin::fnv1a(algo.data(), algo.size());  // the same colour in every report
  return muted[h % (sizeof(muted) / sizeof(muted[0]))];
}

const Algorithm& algorithm_for(ActionSource source, const std::string& learner, SafetyLayer safety) {
  for (const Algorithm& a : algorithms())
    if (a.source == source && a.learner == learner && a.safety == safety) return a;
  throw std::invalid_argument(std::string("no algorithm for this action source under the ") +
                              safety_layer_name(safety) + " safety layer");
}

}  // namespace atacom
