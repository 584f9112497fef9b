// The learners, one line each: name, the config.json section it owns, its
// default config, validation, factory and acting policy. The algorithm table
// (train/algorithms.cpp) names which learner an --algo trains.
#include <stdexcept>

#include "atacom/learner.hpp"
#include "train/adversary.hpp"
#include "train/ppo_learner.hpp"
#include "train/lagrangian_learner.hpp"
#include "train/sac_learner.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

namespace {
// The section both Lagrangian learners read (train/lagrangian.hpp).
LearnerSection lagrangian_section() { return {"lagrangian", lagrangian_default_config_json, lagrangian_resolve_config}; }
}  // namespace

const std::vector<LearnerEntry>& learner_entries() {
  static const std::vector<LearnerEntry> entries = {
      {"sac", "sac", "Soft Actor-Critic on the env's reward", sac_default_config_json, sac_resolve_config,
       make_sac_learner, make_sac_policy},
      {"adversary", "adversary", "SAC maximising the constraint values (train/adversary.hpp)",
       adversary_default_config_json, adversary_resolve_config, make_adversary_learner, make_adversary_policy},
      {"sac-lag", "sac", "SAC-Lagrangian: a cost critic and a multiplier against the episode-cost budget (train/lagrangian_learner.hpp)",
       sac_default_config_json, sac_resolve_config, make_sac_lag_learner, make_sac_policy, {lagrangian_section()}},
      {"ppo", "ppo", "PPO with a clipped surrogate and GAE (train/ppo.hpp)", ppo_default_config_json,
       ppo_resolve_config, make_ppo_learner, make_ppo_policy},
      {"ppo-lag", "ppo", "PPO-Lagrangian: a cost value network, cost GAE and a multiplier against the episode-cost budget (train/lagrangian_learner.hpp)",
       ppo_default_config_json, ppo_resolve_config, make_ppo_lag_learner, make_ppo_policy, {lagrangian_section()}},
  };
  return entries;
}

const LearnerEntry& learner_entry(const std::string& name) {
  for (const auto& e : learner_entries())
    if (e.name == name) return e;
  std::string known;
  for (const auto& e : learner_entries()) known += (known.empty() ? "" : ", ") + e.name;
  throw std::invalid_argument("unknown learner '" + printable_text(name) + "' (known: " + known + ")");
}

}  // namespace atacom
