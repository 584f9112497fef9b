// The learner contract: what the trainer loop knows of a learning algorithm.
//
// A learner (SAC, the adversary, SAC-Lag) owns its config sections of config.json,
// its progress.csv columns, its checkpoint payload, its state hash and its
// summary.json keys. It exposes the Policy that acts during training (with
// sampled actions) and evaluation, and receives every batch transition
// after the env stepped, to store and learn from. The trainer knows nothing
// else of it. Learners register in train/learner_registry.cpp (one line each);
// the algorithm table (train/algorithms.cpp) names which learner an --algo uses.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/evaluate.hpp"
#include "atacom/policy.hpp"
#include "atacom/safety_layer.hpp"

namespace atacom {

struct LearnerContext {
  const EnvSpec* spec = nullptr;        // the env the learner acts in (safety layer included)
  int num_envs = 1;                     // N of the training batch
  uint64_t seed = 0;                    // the run's seed
  const EnvBuffers* initial = nullptr;  // the training batch right after env.seed(seed)
  // The learner's further sections (LearnerEntry::extra_sections), resolved,
  // by name: {"lagrangian": {...}}. Null or empty for learners without any.
  const nlohmann::json* sections = nullptr;
};

class Learner {
 public:
  virtual ~Learner() = default;
  virtual std::string name() const = 0;
  // Acts in training (deterministic = false, per-env streams) and evaluation.
  virtual Policy& policy() = 0;
  // One batch step: the policy chose `actions` (N x act_dim) for `obs`
  // (N x obs_dim, raw), the env stepped, `after` holds its buffers. Store the
  // transitions and run the updates they pay for. May throw on divergence.
  virtual void observe(const float* obs, const double* actions, const EnvBuffers& after) = 0;
  virtual int64_t updates() const = 0;

  // progress.csv: the learner's columns and their values for the next row
  // (means since the previous row; the call starts a new window).
  virtual std::vector<std::string> progress_columns() const = 0;
  virtual std::vector<double> progress_values() = 0;
  // What makes an evaluation the best one (policy_best.bin): higher is
  // better. The env's return by default; the adversary's is how close its
  // episodes come to breaking a row.
  virtual double best_score(const EvalResult& ev) const { return ev.return_mean; }
  // Keys added to summary.json (e.g. "alpha") and to checkpoint.json.
  virtual nlohmann::json summary() const = 0;
  virtual nlohmann::json manifest() const = 0;

  // Checkpoint payload: everything learned or drawn. load() validates its
  // counters against env_steps (the trainer's) and the config, and throws
  // std::runtime_error naming the first impossible value.
  virtual void save(std::ostream& out) const = 0;
  virtual void load(std::istream& in, int64_t env_steps) = 0;
  // Equal hashes mean bitwise equal learner states.
  virtual uint64_t state_hash() const = 0;
};

// A config section that more than one learner reads (the Lagrangian
// learners' "lagrangian"): its one default factory and strict resolver.
struct LearnerSection {
  std::string name;  // "lagrangian"
  nlohmann::json (*default_config)();
  nlohmann::json (*resolve)(const nlohmann::json& section);
};

struct LearnerEntry {
  std::string name;     // "sac", "adversary", "sac-lag"
  std::string section;  // the config.json section of its settings ("sac", "adversary"; sac-lag reads "sac" too)
  std::string help;
  // The one default factory's values (JSON). Per env x algorithm settings
  // are presets (train/presets.hpp), laid over these by resolve_run_config.
  nlohmann::json (*default_config)();
  // Validates a section (defaults with a file's keys laid over) and returns
  // it complete; throws std::invalid_argument naming a bad key.
  nlohmann::json (*resolve)(const nlohmann::json& section);
  std::unique_ptr<Learner> (*make)(const LearnerContext& ctx, const nlohmann::json& resolved);
  // The learner's acting policy for an env, with unset parameters (policy
  // files load into it).
  std::unique_ptr<Policy> (*make_policy)(const EnvSpec& spec, const nlohmann::json& resolved);
  // Sections it reads besides `section` (sac-lag: "lagrangian"); make() finds
  // them resolved in LearnerContext::sections.
  std::vector<LearnerSection> extra_sections = {};
  // Whether the learner reads config section `name`.
  bool owns(const std::string& name) const {
    if (name == section) return true;
    for (const LearnerSection& e : extra_sections)
      if (e.name == name) return true;
    return false;
  }
};

const std::vector<LearnerEntry>& learner_entries();
// Throws std::invalid_argument for an unknown name (listing the known ones).
const LearnerEntry& learner_entry(const std::string& name);

}  // namespace atacom
