// The algorithm table: every `--algo` name is an action source composed
// with a safety layer, the product of the sources below and the layers of
// the safety table (include/atacom/safety_layer.hpp). This is the one place
// algorithm names are made and compared; the env registry and the trainer
// loop know none of them.
//
//   source \ layer      none        atacom           safelayer        ...
//   SAC learner         sac         atacom-sac       safelayer-sac
//   PPO learner         ppo         atacom-ppo       safelayer-ppo
//   linear attractor    la          la-atacom        la-safelayer
//   random actions      random      random-atacom    random-safelayer
//   zero actions        zero        zero-atacom      zero-safelayer
//   SAC adversary       attack      attack-atacom    attack-safelayer
//
// A learner's name puts the layer first (the paper's "ATACOM-SAC"), the
// evaluated sources and the adversary put it last (the paper's
// "LA-ATACOM"). Learner sources train (and are evaluated as they go); the
// others are evaluated only. The adversary learns to reach the largest
// constraint value (train/adversary.hpp), the attack of `atacom attack`.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "atacom/safety_layer.hpp"

namespace atacom {

enum class ActionSource : uint8_t {
  Learner = 0,    // a registered learner (Algorithm::learner) acts and learns
  Attractor = 1,  // the env family's linear attractor (EnvEntry::make_attractor)
  Random = 2,     // U[-1, 1] per action component
  Zero = 3,       // all zeros
};

struct Algorithm {
  std::string name;         // "atacom-sac"
  ActionSource source;
  SafetyLayer safety;
  std::string learner;      // learner registry name when source == Learner ("sac", "ppo", "adversary"), else ""
  std::string help;
  bool learns() const { return source == ActionSource::Learner; }
};

// One action source: a row of the table above.
struct ActionSourceEntry {
  std::string stem;      // "sac", "la": the name under no layer
  ActionSource source;
  std::string learner;   // learner registry name when source == Learner, else ""
  bool layer_first;      // "atacom-sac" (true) or "la-atacom" (false)
  std::string help;      // "SAC (trains)"
};
const std::vector<ActionSourceEntry>& action_sources();

const std::vector<Algorithm>& algorithms();
std::vector<std::string> algorithm_names();
// Throws std::invalid_argument for an unknown name, listing the known ones.
const Algorithm& find_algorithm(const std::string& name);
// The colour of an algorithm in every figure (report boxes, curves,
// scatters, a run's progress.svg): fixed per name, colour-blind safe
// (Okabe-Ito for the paper's and the safe-RL baselines' names, Paul Tol's
// muted set for the others, chosen by a hash of the name).
std::string algorithm_color(const std::string& algo);

// The algorithm of a source (and learner) under a layer, e.g. the adversary
// through ATACOM = "attack-atacom". Throws if there is none.
const Algorithm& algorithm_for(ActionSource source, const std::string& learner, SafetyLayer safety);

}  // namespace atacom
