// The Lagrange multiplier of the constrained learners (sac-lag, ppo-lag):
// one per run, moved by every finished training episode's cost against the
// per-episode budget (a constrained MDP: max return s.t. E[episode cost] <=
// cost_limit). Both learners read the config section "lagrangian":
//   cost_limit  the per-episode budget d (summed EnvBuffers::cost, 0/1 per step)
//   lr          plain gradient ascent on lambda: lambda += lr (J - d)
//   kp, ki, kd  PID-Lagrangian (Stooke, Achiam and Abbeel, ICML 2020)
//   init        the starting multiplier
// Per episode cost J_t (t = 1, 2, ...; the episodes in the order they end,
// env index order within a batch step), e_t = J_t - d:
//   I_t      = max(0, I_{t-1} + (lr + ki) e_t),   I_0 = init
//   lambda_t = max(0, I_t + kp e_t + kd max(0, J_t - J_{t-1}))   (no D term at t = 1)
// lr and ki both integrate the error (gradient ascent is PID's integral
// term alone); with kp = kd = 0 the multiplier is the projected gradient
// ascent of the textbook Lagrangian method. It rises while episodes cost
// more than the budget and falls (to 0 at least) while they cost less.
#pragma once
#include <cstdint>
#include <iosfwd>

#include <nlohmann/json.hpp>

namespace atacom {

struct LagrangianConfig {
  double cost_limit = 5.0;  // per episode (1 % of the 500-step horizon of the shipped envs)
  double lr = 0.05;
  double kp = 0.0, ki = 0.0, kd = 0.0;
  double init = 0.0;
};
// The one default factory (LagrangianConfig{} holds the same values): a
// budget of 5 cost steps per episode and gradient ascent with lr 0.05 per
// episode; the per-env budgets are preset entries (configs/presets/paper.json).
LagrangianConfig default_lagrangian_config();
void to_json(nlohmann::json& j, const LagrangianConfig& c);
void from_json(const nlohmann::json& j, LagrangianConfig& c);  // strict: unknown keys, negatives, non-finite refused

class LagrangeMultiplier {
 public:
  explicit LagrangeMultiplier(const LagrangianConfig& cfg = {});
  // One finished episode's summed cost.
  void update(double episode_cost);
  double value() const { return value_; }
  int64_t updates() const { return updates_; }
  const LagrangianConfig& config() const { return cfg_; }
  // The controller's state (value, integral, last episode cost, count).
  void save(std::ostream& out) const;
  void load(std::istream& in);  // throws std::runtime_error on a negative or non-finite value
 private:
  LagrangianConfig cfg_;
  double value_ = 0, integral_ = 0, last_cost_ = 0;
  int64_t updates_ = 0;
};

// Learner registry hooks for the shared section (train/learner_registry.cpp).
nlohmann::json lagrangian_default_config_json();
nlohmann::json lagrangian_resolve_config(const nlohmann::json& section);

}  // namespace atacom
