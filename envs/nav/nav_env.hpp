// NavEnv: a differential-drive TIAGo base reaches a random goal in a 7 m x
// 5 m room while a Fetch robot drives to its own random goals, ignoring TIAGo
// (paper: "Navigation: Differential-Drive Robot"; reference digest 4.3).
//
// Simulation: one single-threaded Box2D 2.4 world per env (zero gravity, top
// down); the four walls are static boxes, TIAGo and Fetch are dynamic discs
// whose velocities are set every step so that Box2D's position update lands
// exactly on the unicycle's closed-form step (docs/envs_nav.md). TBB runs
// fixed blocks of worlds in parallel. A TIAGo contact (wall or Fetch), read
// from Box2D's contact pairs at the state the step reached, ends the episode
// with the collision reward.
//
// Observation (18): goal x, y | TIAGo x, y, cos, sin | TIAGo vx, vy, omega |
// Fetch x, y, cos, sin | Fetch vx, vy, omega | previous action (2).
// Action (2): [v / v_max, omega / w_max] in [-1, 1].
//
// After each step the batch state is mirrored into the structure-of-arrays
// NavBatch, which the constraint kernel (nav_constraints.hpp) and the
// observation read; Box2D holds no state that the next step depends on
// besides the body poses, so snapshots store the SoA and rebuild the worlds.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "envs/nav/fetch_policy.hpp"
#include "kernels/nav_constraints.hpp"
#include "atacom/rng.hpp"
#include "atacom/control_affine_env.hpp"
#include "atacom/system.hpp"

class b2World;
class b2Body;

namespace atacom {

struct NavConfig {
  double dt = 1.0 / 30.0;   // control period = Box2D step, s
  int horizon = 500;        // steps per episode
  int block = 64;           // envs per parallel block (performance only)

  struct Room {
    double x = 3.5;                     // inner wall faces at x = +-x, m
    double y = 2.5;                     // and y = +-y, m
    double wall_thickness = 0.4;        // m
    double spawn_fraction = 0.75;       // starts and goals uniform in spawn_fraction * room
    double min_start_separation = 0.8;  // TIAGo-Fetch centre distance at reset, m
  } room;

  struct Tiago {
    double radius = 0.4;                  // collision disc (arms tucked), m
    double v_max = 1.0;                   // m/s at |a_0| = 1
    double w_max = 1.0471975511965976;    // rad/s at |a_1| = 1 (pi/3)
  } tiago;

  struct Fetch {
    double radius = 0.3;  // m
    FetchPolicyParams policy;
  } fetch;

  // r = -w_d |e| - |e_theta| sigmoid(g (|e| - o)) / pi - w_a |a - a_prev|
  //     + bonus [|e| < goal_radius];  collision: r = collision_reward.
  struct Reward {
    double distance_weight = 1.0;
    double heading_gain = 20.0;
    double heading_offset = 0.3;
    double action_change_weight = 0.1;
    double goal_radius = 0.2;
    double goal_bonus = 10.0;
    double collision_reward = -1000.0;
  } reward;

  // Geometry and ATACOM slack settings of the 5 constraint rows
  // (docs/envs_nav.md explains the choices). The env reports the task's rows
  // (margins only, EnvBuffers::constraints); ATACOM enforces stricter rows
  // built from them with the look-ahead, sweep and buffer below, each of
  // which is >= the task's row, so keeping them <= 0 keeps the task's <= 0.
  struct Constraints {
    double wall_margin = 0.1;       // m, reference 3.5
    double fetch_margin = 0.1;      // m, reference 3.5
    // ATACOM's rows: wall rows at the point wall_lookahead ahead of TIAGo
    // with radius r_T + wall_lookahead, moved in by wall_buffer; the Fetch
    // row from the point fetch_lookahead ahead (radius r_T + fetch_lookahead)
    // to the segment of length fetch_sweep ahead of Fetch along its heading.
    // The look-aheads give the rows an omega entry (ATACOM can turn TIAGo);
    // the sweep makes TIAGo leave Fetch's path before it is pinned.
    double wall_lookahead = 0.1;    // m
    double fetch_lookahead = 0.2;   // m
    double fetch_sweep = 0.7;       // m (Fetch's top speed x 1 s)
    double wall_buffer = 0.02;      // m
    std::string slack = "softcorner";
    std::string basis = "projected";
    // Slack shape and floor per row. An active row weighs 1 / a(s)^2 in the
    // projection; where Fetch pins TIAGo against a wall the rows conflict and
    // the exact, static walls must win: a_wall(s) << a_fetch(tol_fetch) for
    // every s TIAGo can cover in one step (v_max dt = 3.3 cm):
    // e^{3 * 0.033} - 1 = 0.10 < e^{4 * 0.1} - 1 = 0.49.
    double wall_beta = 3.0;
    double wall_tol = 1e-6;
    double fetch_beta = 4.0;
    double fetch_tol = 0.1;
    double violation_tolerance = 1e-3;  // EnvSpec::constraint_tolerance of every row, m
  } constraints;

  // Contacts end the episode, so the solver never resolves a touching
  // contact: one iteration each is enough (docs/envs_nav.md).
  struct Box2D {
    int velocity_iterations = 1;
    int position_iterations = 1;
  } box2d;

  // Quality target (time_to_target, docs/training.md): within 0.5 m of the goal.
  EnvTarget target{0.5, {}};
};

// The one default factory: the paper's navigation env.
NavConfig default_nav_config();
// Throws std::invalid_argument naming the first bad field.
void validate(const NavConfig& c);
void to_json(nlohmann::json& j, const NavConfig& c);
void from_json(const nlohmann::json& j, NavConfig& c);  // strict: every key, no unknown key; validates

NavConstraintGeometry nav_constraint_geometry(const NavConfig& c);
DiffDriveSystem nav_tiago_system(const NavConfig& c);

// Observation layout.
inline constexpr int kNavObsDim = 18;
inline constexpr int kNavActDim = 2;

// Info columns (EnvSpec::info_names order).
enum NavInfo : int {
  kNavInfoCollision = 0,      // Sum: TIAGo touched a wall or Fetch
  kNavInfoWallCollision,      // Sum: TIAGo touched a wall
  kNavInfoRobotCollision,     // Sum: TIAGo touched Fetch
  kNavInfoFinalDistance,      // Last: distance to the goal
  kNavInfoMeanDistance,       // Mean: distance to the goal
  kNavInfoAtGoal,             // Last: 1 when within reward.goal_radius
  kNavInfoFetchDistance,      // Last: TIAGo-Fetch centre distance
  kNavInfoFetchGoals,         // Sum: goals Fetch reached
  kNavInfoNanAction,          // Sum: actions with a NaN component (treated as 0)
  kNavInfoCount
};

// Structure-of-arrays state of N envs, written by NavEnv after every step and
// reset. Poses are the Box2D bodies' float values widened to double.
struct NavBatch {
  int N = 0;
  std::vector<double> tiago;        // (N x 3) TIAGo x, y, theta (theta unwrapped, as Box2D integrates it)
  std::vector<double> tiago_vel;    // (N x 3) world vx, vy, omega TIAGo moved with in the last step
  std::vector<double> fetch;        // (N x 3) Fetch x, y, theta
  std::vector<double> fetch_vel;    // (N x 3) world vx, vy, omega Fetch moves with in the next step
  std::vector<double> fetch_cmd;    // (N x 2) Fetch v, omega for the next step (its controller at this state)
  std::vector<double> goal;         // (N x 2) TIAGo goal
  std::vector<double> fetch_goal;   // (N x 2) Fetch goal
  std::vector<double> prev_action;  // (N x 2) last normalised action applied (0 after reset)
  std::vector<int32_t> t;           // (N) steps taken in the current episode
  std::vector<double> ret;          // (N) undiscounted return of the current episode so far
  std::vector<Rng> rng;             // (N) stream (seed, env id)

  void resize(int n);
};

class NavEnv final : public ControlAffineEnv {
 public:
  NavEnv(const NavConfig& config, int num_envs);
  ~NavEnv() override;
  NavEnv(const NavEnv&) = delete;
  NavEnv& operator=(const NavEnv&) = delete;

  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override;
  void load_state(std::istream& in) override;

  // Sections: "box2d" (world steps and contact queries), "env" (the rest of
  // step: actions, Fetch controller, reward, observation, resets). Seconds
  // are summed over blocks, i.e. thread-seconds.
  std::vector<std::string> profile_sections() const override;
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  // ATACOM: n = 3, m = 2, k = 5, p = 3 (Fetch's pose), dense G, no drift, K_c = 1/dt.
  ProjectorModel projector_model() const override;
  void constraint_model(ProjectorBatch& pb, int begin, int end) const override;

  const NavConfig& config() const { return cfg_; }
  const NavBatch& state() const { return st_; }

  // Scripted start for env i (tests, demos): poses [x, y, theta] and goals
  // [x, y]; the episode restarts there (t = 0, zero velocities). Poses are
  // rounded to Box2D's float. No check that the start is collision free.
  void place(int i, const double* tiago_pose, const double* fetch_pose, const double* goal,
             const double* fetch_goal);

 private:
  struct World;
  void build_world(int i);
  void reset_env(int i);
  void start_episode(int i);  // after poses and goals are set: bodies, Fetch command, counters
  int update_fetch_command(int i);  // returns 1 when Fetch reached its goal and got a new one
  void write_obs(int i, float* o) const;
  void step_block(const double* actions, int lo, int hi, int block_index);

  NavConfig cfg_;
  NavConstraintGeometry geom_;       // ATACOM's rows
  NavConstraintGeometry task_geom_;  // the task's rows, reported in EnvBuffers::constraints
  DiffDriveSystem sys_;
  EnvSpec spec_;
  NavBatch st_;
  std::vector<std::unique_ptr<World>> worlds_;  // (N)
  // Per-step scratch, (N) each: written and read inside one block.
  std::vector<double> act_;          // (N x 2) sanitised action
  std::vector<uint8_t> nan_;         // (N) action had a NaN
  std::vector<uint8_t> hit_wall_;    // (N) TIAGo-wall contact at the reached state
  std::vector<uint8_t> hit_fetch_;   // (N) TIAGo-Fetch contact at the reached state
  bool profiling_ = false;
  std::vector<double> profile_acc_;  // (num_blocks x 2) seconds per block and section
};

// Registry factory: resolved JSON config -> NavEnv.
nlohmann::json nav_default_config_json();
std::unique_ptr<BatchEnv> make_nav_env(const nlohmann::json& config, int num_envs);

}  // namespace atacom
