// The batched environment contract: every env in this project implements it.
//
// One object holds N envs. reset() and step() work on all of them at once and
// write into preallocated structure-of-arrays buffers (no allocation per step).
// Actions are always normalised to [-1, 1]^act_dim; the env maps them to its
// physical units. Autoreset happens in the same step: an env whose episode
// ended writes its true last observation to final_obs and its first
// observation of the next episode to obs, so no action and no step is lost.
// Randomness comes from per-env streams keyed by (seed, env id): results do
// not depend on the thread count or on how N is partitioned.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <limits>
#include <string>
#include <vector>

namespace atacom {

// How a per-step info column becomes one number per episode.
enum class InfoReduce : uint8_t {
  Last = 0,  // value at the episode's last step (e.g. final_distance)
  Sum = 1,   // summed over the episode (e.g. collision, violation counts)
  Max = 2,   // maximum over the episode (e.g. max_constraint)
  Mean = 3,  // mean over the episode's steps
};

// The env's quality target, the bar of `atacom train`'s time_to_target
// (docs/training.md): an evaluation meets it when its mean final_distance is
// <= distance and every info column named in zero_info averages 0 over the
// evaluation episodes (HRI-Sim: no spill). The env declares it as data, from
// its config keys target_distance and target_zero_info (src/core/env_target.hpp).
struct EnvTarget {
  double distance = std::numeric_limits<double>::quiet_NaN();  // m; NaN: the env declares no target
  std::vector<std::string> zero_info;                          // info columns that must be 0 in evaluation
  bool defined() const { return distance == distance; }
};

// What an info column is for, declared by the env beside its name and
// reduction, so the consumers that pick or total columns (the trainer, the
// evaluator, rollout, the adversary, render) look the role up, never the name.
enum class InfoRole : uint8_t {
  Diagnostic = 0,  // only its own column
  Contact,         // steps with a ground-truth contact of one kind (nav's wall_collision, HRI's human_collision)
  AnyContact,      // steps with any ground-truth contact (the env's "collision"): the runs' collision count
  EpisodeEvent,    // 1 for an episode with the event (HRI-Sim's spill flags): totals count episodes
  GoalDistance,    // distance to the goal at the episode's end: the quality metric (final_distance)
};

inline bool is_contact(InfoRole r) { return r == InfoRole::Contact || r == InfoRole::AnyContact; }

// The name an event column's totals carry in the rollout JSON and the run
// summaries: a contact column "<x>collision" -> "<x>collisions", an episode
// event "spill" / "spill_<deg>" -> "spills" / "spills_<deg>" (the plural of
// its first word); "" for a column that counts no events.
inline std::string event_total_name(const std::string& name, InfoRole role) {
  if (is_contact(role)) return name + "s";
  if (role != InfoRole::EpisodeEvent) return "";
  const size_t word = name.find('_');
  return word == std::string::npos ? name + "s" : name.substr(0, word) + "s" + name.substr(word);
}

struct EnvSpec {
  std::string name;
  int obs_dim = 0;
  int act_dim = 0;
  std::vector<float> obs_low, obs_high;       // (obs_dim) bounds of the observation
  double dt = 0.0;                            // control period, s
  int horizon = 0;                            // steps before truncation
  double gamma = 0.99;                        // the task's discount (evaluate()'s discounted return)
  int num_constraints = 0;                    // k: columns of EnvBuffers::constraints
  std::vector<double> constraint_tolerance;   // (k) a row violates when c > tolerance
  std::vector<std::string> constraint_names;  // (k)
  // Info columns whose non-zero value is a safety event (a collision, a
  // joint-limit violation): the step's cost is 1 then (EnvBuffers::cost).
  std::vector<std::string> cost_events;
  std::vector<std::string> info_names;        // columns of EnvBuffers::info
  std::vector<InfoReduce> info_reduce;        // (info_names.size()) per-episode aggregation
  std::vector<InfoRole> info_role;            // (info_names.size()) what each column is for; missing entries
                                              // (a layer's appended columns) are Diagnostic
  EnvTarget target;                           // quality target (undefined: none)

  InfoRole role(size_t col) const { return col < info_role.size() ? info_role[col] : InfoRole::Diagnostic; }
  // The first column with role r, or -1.
  int column_with(InfoRole r) const {
    for (size_t c = 0; c < info_names.size(); ++c)
      if (role(c) == r) return int(c);
    return -1;
  }
};

struct EnvBuffers {
  int N = 0;
  std::vector<float> obs;             // (N x obs_dim) observation to act on next
  std::vector<float> final_obs;       // (N x obs_dim) observation the last step reached (== obs unless done)
  std::vector<float> reward;          // (N) reward of the last step
  // The two costs of the last step (docs/training.md, "Cost"):
  std::vector<float> cost;            // (N) 0 or 1: 1 when a row exceeds its tolerance or a cost event happened (step_cost)
  std::vector<float> cost_continuous; // (N) max(0, max_i c_i) at the state the step reached
  std::vector<uint8_t> terminated;    // (N) episode ended in a terminal state (no bootstrap)
  std::vector<uint8_t> truncated;     // (N) episode hit the horizon (bootstrap from final_obs)
  std::vector<double> constraints;    // (N x k) constraint values at the state the step reached
  std::vector<float> info;            // (N x info_names.size()) per-step diagnostics of the last step
  std::vector<double> episode_return; // (N) undiscounted return of the episode that just ended
  std::vector<int32_t> episode_length;// (N) length of the episode that just ended

  void resize(const EnvSpec& spec, int N);
  // Copies every array's values from `from` (same shapes) into this one's
  // storage: views on these arrays (the Python module's, the trainer's)
  // stay valid across load_state, which a move or swap would break.
  void copy_values_from(const EnvBuffers& from);
  bool done(int i) const { return terminated[i] || truncated[i]; }
};

// Safety-Gymnasium's per-step cost: 1 when one of the k rows `c` exceeds its
// tolerance (c_r > tol_r, as EnvSpec::constraint_tolerance) or `event` (a
// collision or joint-limit event of the step), else 0. A NaN row does not
// count (as for the violation counters).
inline float step_cost(const double* c, const double* tol, int k, bool event) {
  bool v = event;
  for (int r = 0; r < k && !v; ++r) v = c[r] > tol[r];
  return v ? 1.0f : 0.0f;
}

class BatchEnv {
 public:
  virtual ~BatchEnv() = default;
  virtual const EnvSpec& spec() const = 0;
  int num_envs() const { return buffers_.N; }
  const EnvBuffers& buffers() const { return buffers_; }
  EnvBuffers& buffers() { return buffers_; }

  // Re-key every env's random stream with (seed, env id) and reset all envs.
  virtual void seed(uint64_t seed) = 0;
  // Reset the envs with mask[i] != 0 (all when mask == nullptr); writes obs.
  virtual void reset(const uint8_t* mask = nullptr) = 0;
  // Advance every env by one control step. actions: (N x act_dim), each in
  // [-1, 1] (values outside are clipped; NaN is treated as 0 and counted in
  // info where the env reports it). Same-step autoreset.
  virtual void step(const double* actions) = 0;

  // Snapshot/restore of the complete batch state (including RNG streams and
  // step counters), such that restore + step reproduces the original bitwise.
  virtual void save_state(std::ostream& out) const = 0;
  virtual void load_state(std::istream& in) = 0;

  // Optional time split of step() into named sections (benchmarks only).
  // Envs that support it accumulate wall seconds per section while enabled.
  virtual std::vector<std::string> profile_sections() const { return {}; }
  virtual void set_profiling(bool /*on*/) {}
  virtual std::vector<double> profile_seconds() const { return {}; }  // (sections), since last enable

 protected:
  EnvBuffers buffers_;
};

}  // namespace atacom
