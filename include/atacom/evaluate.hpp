// The evaluator: the paper's metrics for any policy on any env (with or
// without a safety layer), learned and hand-coded policies alike.
//
// Episodes run in parallel, one per env of the batch; when `episodes`
// exceeds the batch size they run in rounds. Round r seeds the env with
// eval_env_seed(seed, r) and episode j draws its action noise from stream
// (seed, kEvalStream + j): every evaluation of a run (seed) starts from the
// same states, whatever the algorithm, so `la` and `sac` with the same seed
// face the same start states and goals. The trainer evaluates through this
// function; its numbers for SAC are the ones the trainer wrote before the
// evaluator was split out (tests/test_evaluate.cpp holds it to them).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "atacom/env.hpp"
#include "atacom/policy.hpp"

namespace atacom {

struct EvalResult {
  int episodes = 0;
  double return_mean = 0, return_std = 0;                       // undiscounted, over episodes (population std)
  double discounted_return_mean = 0, discounted_return_std = 0;  // sum_t gamma^t r_t, gamma = EnvSpec::gamma
  int early_terminations = 0;     // episodes that ended terminated (collision, limit), not by the horizon
  double avg_episode_steps = 0;
  double violations = 0;          // steps per episode with a constraint row above its tolerance
  double cost_mean = 0;           // per episode the summed step cost (EnvBuffers::cost, 0 or 1), averaged
  double max_constraint = 0;      // largest constraint value of any row at any step (NaN: no rows)
  double episode_max_constraint = 0;  // per episode the largest value of any row, averaged (NaN: no rows)
  double final_distance = 0;      // the env's goal-distance info column (InfoRole::GoalDistance; NaN: the env has none)
  double collisions = 0;          // the env's every-contact info column (InfoRole::AnyContact): contacts per episode (NaN: none)
  std::vector<std::string> info_names;  // the env's info columns
  std::vector<InfoRole> info_roles;     // (info_names.size()) what each is for (EnvSpec::info_role)
  std::vector<double> info;       // per info column: reduced per episode (InfoReduce), averaged over episodes
};

// Runs `episodes` episodes (each until done, or at most spec().horizon steps;
// 100000 for envs without one). Throws std::invalid_argument on mismatched
// dimensions or episodes < 1. Allocates its scratch per call (not per step).
EvalResult evaluate(BatchEnv& env, Policy& policy, int episodes, uint64_t seed, bool deterministic);

// The env seed of evaluation round r (round 0: seed ^ a fixed salt).
uint64_t eval_env_seed(uint64_t seed, int round);

// The quality target's verdict on an evaluation (EnvTarget in atacom/env.hpp):
// the target is defined, final_distance <= target.distance, and every
// zero_info column averages exactly 0 (a column the result lacks never meets).
bool meets_target(const EnvTarget& target, const EvalResult& r);
// {"distance": m, "zero_info": [names]}, or null when the env declares no target.
nlohmann::json target_json(const EnvTarget& target);

// {"eval_return_mean", "eval_return_std", "eval_discounted_return_mean", ...,
//  "early_terminations", "avg_episode_steps", "violations", "eval_cost_mean", "eval_max_constraint",
//  "eval_episode_max_constraint",
//  one key per info column, collision columns also as "<name>s"}; non-finite
// numbers as null. The keys summary.json uses for the final and the best evaluation.
nlohmann::json eval_json(const EvalResult& r);

}  // namespace atacom
