#include "train/algorithms.hpp"
#include "src/core/config_json.hpp"

#include <stdexcept>

namespace atacom {

const std::vector<Algorithm>& algorithms() {
  using A = ActionSource;
  using S = SafetyLayer;
  static const std::vector<Algorithm> table = {
      {"sac", A::Learner, S::None, "sac", "SAC on the plain env"},
      {"atacom-sac", A::Learner, S::Atacom, "sac", "SAC acting on ATACOM's tangent space (the paper's method)"},
      {"safelayer-sac", A::Learner, S::SafeLayer, "sac", "SAC through SafeLayer's action correction"},
      {"ppo", A::Learner, S::None, "ppo", "PPO on the plain env"},
      {"atacom-ppo", A::Learner, S::Atacom, "ppo", "PPO acting on ATACOM's tangent space"},
      {"safelayer-ppo", A::Learner, S::SafeLayer, "ppo", "PPO through SafeLayer's action correction"},
      {"la", A::Attractor, S::None, "", "the env's linear attractor, evaluated"},
      {"la-atacom", A::Attractor, S::Atacom, "", "the linear attractor's output as ATACOM's alpha, evaluated"},
      {"la-safelayer", A::Attractor, S::SafeLayer, "", "the linear attractor corrected by SafeLayer, evaluated"},
      {"random", A::Random, S::None, "", "uniform random actions, evaluated"},
      {"random-atacom", A::Random, S::Atacom, "", "uniform random alpha through ATACOM, evaluated"},
      {"random-safelayer", A::Random, S::SafeLayer, "", "uniform random actions through SafeLayer, evaluated"},
      {"zero", A::Zero, S::None, "", "zero actions, evaluated"},
      {"zero-atacom", A::Zero, S::Atacom, "", "zero alpha through ATACOM (pure correction), evaluated"},
      {"zero-safelayer", A::Zero, S::SafeLayer, "", "zero actions through SafeLayer, evaluated"},
      {"attack", A::Learner, S::None, "adversary", "SAC adversary maximising the constraint values, no safety layer"},
      {"attack-atacom", A::Learner, S::Atacom, "adversary", "SAC adversary against ATACOM"},
      {"attack-safelayer", A::Learner, S::SafeLayer, "adversary", "SAC adversary against SafeLayer"},
  };
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

const Algorithm& algorithm_for(ActionSource source, const std::string& learner, SafetyLayer safety) {
  for (const Algorithm& a : algorithms())
    if (a.source == source && a.learner == learner && a.safety == safety) return a;
  throw std::invalid_argument(std::string("no algorithm for this action source under the ") +
                              safety_layer_name(safety) + " safety layer");
}

}  // namespace atacom
