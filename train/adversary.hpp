// The adversary: a SAC learner whose reward is how close it gets to
// breaking a constraint, acting through the run's safety layer (`atacom
// attack`, algorithms attack, attack-atacom, attack-safelayer).
//
// Reward of env i after a step (replaces the env's reward in the replay):
//   r_i = min(max_r c_ir / s_r, reward_cap) + collision_bonus * [ground-truth collision]
// c_ir: constraint row r at the reached state (EnvBuffers::constraints);
// s_r = max(scale_floor, mean over the training envs of |c_r| at their first
// state): each row's value is measured in units of its typical distance
// from the boundary, so approaching any boundary pays and the closest row
// sets the reward (about -1 at a typical start, 0 on a boundary, up to
// reward_cap beyond it). Rewards are <= 0 until a boundary is crossed, so
// ending an episode early (a collision terminates it) pays as well, and the
// bonus marks the collision itself. The collision flag is any contact info
// column (InfoRole::Contact, AnyContact) being > 0.
//
// Besides the SAC state it tracks the largest constraint value reached and
// the `worst_states` episodes that came closest (their observation, which
// holds q or the pose, and every row at that step), for summary.json.
#pragma once
#include <memory>
#include <vector>

#include "train/sac_learner.hpp"

namespace atacom {

struct AdversaryConfig {
  SacConfig sac;                 // the adversary's own SAC settings (not the env's per-layer ones)
  double collision_bonus = 100.0; // added to the reward of a step that collides
  double scale_floor = 0.05;     // lower bound of the row scales, in the rows' units (m, rad)
  double reward_cap = 1.0;       // cap of the row term beyond the boundary
  int worst_states = 5;          // episodes kept in summary.json's adversary.worst
};
// The one default factory: an attack runs for tens of thousands of steps,
// not millions, so a small fast SAC: 64-64 networks, lr 1e-3 (alpha 3e-4),
// initial replay and warm-up 1000, replay 100k, gamma 0.99; bonus 100
// (a collision outweighs any path of row terms), floor 0.05, cap 1, 5 worst states.
AdversaryConfig default_adversary_config();
void to_json(nlohmann::json& j, const AdversaryConfig& c);
void from_json(const nlohmann::json& j, AdversaryConfig& c);  // strict; the "sac" subsection as SacConfig

class AdversaryLearner final : public Learner {
 public:
  // Throws std::invalid_argument for envs without constraint rows.
  AdversaryLearner(const LearnerContext& ctx, const AdversaryConfig& config);

  std::string name() const override { return "adversary"; }
  Policy& policy() override { return sac_.policy(); }
  void observe(const float* obs, const double* actions, const EnvBuffers& after) override;
  int64_t updates() const override { return sac_.updates(); }
  // The best evaluation: the largest per-episode maximum constraint value.
  double best_score(const EvalResult& ev) const override { return ev.episode_max_constraint; }
  std::vector<std::string> progress_columns() const override;
  std::vector<double> progress_values() override;
  // {"alpha", "adversary": {"max_constraint", "max_constraint_row", "row_scale", "worst": [...]}}
  nlohmann::json summary() const override;
  nlohmann::json manifest() const override;
  void save(std::ostream& out) const override;
  void load(std::istream& in, int64_t env_steps) override;
  uint64_t state_hash() const override;

  double max_constraint() const { return max_c_; }
  const std::vector<float>& last_reward() const { return reward_; }  // (N) the shaped reward of the last step
  const std::vector<double>& row_scale() const { return scale_; }

 private:
  struct Record {                 // the step of an episode closest to breaking a row
    double value = -1e300;        // max_r c_r at that step
    int32_t row = -1;             // its row
    int32_t env = -1;
    int64_t env_steps = 0;        // training env steps when it was reached
    std::vector<float> obs;       // (obs_dim) observation of the reached state
    std::vector<double> c;        // (k) every row there
  };
  static void keep(std::vector<Record>& list, const Record& r, int cap);  // sorted, at most cap
  nlohmann::json record_json(const Record& r) const;
  static void save_record(std::ostream& out, const Record& r);
  Record load_record(std::istream& in) const;

  AdversaryConfig cfg_;
  EnvSpec spec_;
  int N_, k_, ni_;
  SacLearner sac_;
  std::vector<double> scale_;     // (k) row scales s_r
  std::vector<int> collision_cols_;
  std::vector<float> reward_;     // (N) shaped reward of the last step
  int64_t steps_ = 0;             // env steps observed
  double max_c_ = -1e300;         // largest constraint value so far
  int32_t max_row_ = -1;
  double reward_sum_ = 0;         // since the last progress row
  int64_t reward_n_ = 0;
  std::vector<Record> current_;   // (N) the running episode's closest step
  std::vector<Record> worst_;     // finished episodes, largest value first
};

// What `atacom attack` prints, from an attack run's summary.json: {"env",
// "algo", "safety", "seed", "steps", "episodes", "terminations",
// "collisions" (ground truth, training), "violations" (env-steps with a row
// above its tolerance), "max_constraint" (over every training step and row),
// "max_constraint_row", "worst" (the adversary's closest episodes),
// "wall_s", "per_s"}.
nlohmann::json attack_result(const nlohmann::json& summary);

nlohmann::json adversary_default_config_json();
nlohmann::json adversary_resolve_config(const nlohmann::json& section);
std::unique_ptr<Learner> make_adversary_learner(const LearnerContext& ctx, const nlohmann::json& resolved);
std::unique_ptr<Policy> make_adversary_policy(const EnvSpec& spec, const nlohmann::json& resolved);

}  // namespace atacom
