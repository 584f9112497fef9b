// NavConfig: the navigation env's parameters (room, robots, reward,
// constraint rows, Box2D solver), their default factory, validation and
// strict JSON (envs/nav/nav_config.cpp).
#pragma once
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "atacom/env.hpp"
#include "atacom/system.hpp"
#include "envs/nav/fetch_policy.hpp"
#include "kernels/nav_constraints.hpp"

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

}  // namespace atacom
