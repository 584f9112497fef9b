// The static model of the navigation env: its validated config and what is
// derived from it once (the constraint geometries, TIAGo's system, the spec).
// Built once per NavEnv and read by every kernel on every thread. The
// per-env state is NavBatch (envs/nav/nav_batch.hpp), Box2D's bodies
// NavWorlds (envs/nav/nav_world.hpp), the kernels over an env range
// envs/nav/nav_kernels.hpp.
#pragma once
#include "atacom/env.hpp"
#include "atacom/projector.hpp"
#include "atacom/system.hpp"
#include "envs/nav/nav_config.hpp"
#include "kernels/nav_constraints.hpp"

namespace atacom {

// Observation layout (envs/nav/nav_env.hpp lists the entries).
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

struct NavModel {
  // Validates the config (std::invalid_argument naming the first bad field).
  explicit NavModel(const NavConfig& config);

  NavConfig config;
  NavConstraintGeometry geom;       // ATACOM's rows
  NavConstraintGeometry task_geom;  // the task's rows, reported in EnvBuffers::constraints
  DiffDriveSystem sys;              // TIAGo's unicycle
  EnvSpec spec;
  double spawn_x = 0, spawn_y = 0;  // starts and goals are uniform in [-spawn_x, spawn_x] x [-spawn_y, spawn_y]
};

// ATACOM: n = 3, m = 2, k = 5, p = 3 (Fetch's pose), dense G, no drift, K_c = 1/dt.
ProjectorModel nav_projector_model(const NavModel& m);

}  // namespace atacom
