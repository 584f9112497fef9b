// Kernels of the navigation env: free functions (const NavModel&, NavBatch&,
// NavWorlds&, env range) that write only the batch, the worlds of their
// envs and the env buffers they are given; NavEnv calls them over fixed
// parallel blocks (NavConfig::block), so ranges run concurrently. Beside
// them the scalar one-env reference step (nav_step_reference,
// envs/nav/nav_reference.cpp) that the range kernel is tested against.
#pragma once
#include <cstdint>

#include "atacom/env.hpp"
#include "atacom/rng.hpp"
#include "envs/nav/nav_batch.hpp"
#include "envs/nav/nav_model.hpp"
#include "envs/nav/nav_world.hpp"

namespace atacom {

// Thread-seconds of step's two sections (profiling): Box2D's world steps and
// contact queries, and the rest (actions, Fetch's controller, reward,
// observation, resets).
struct NavProfile {
  double box2d = 0.0;
  double env = 0.0;
};

// Reset envs e in [begin, end) with mask[e] != 0 (all when mask is null):
// draws starts and goals from env e's stream and writes obs, final_obs,
// constraints, costs, reward, done flags and info of the env.
void nav_reset_range(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, const uint8_t* mask, int begin,
                     int end);

// Scripted start of env e: poses [x, y, theta] (rounded to Box2D's float) and
// goals [x, y]; the episode restarts there (t = 0, zero velocities). No check
// that the start is collision free.
void nav_place(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, int e, const double* tiago_pose,
               const double* fetch_pose, const double* goal, const double* fetch_goal);

// One control step of envs [begin, end): actions (N x 2, normalised; NaN ->
// 0 and counted, clipped to [-1, 1]) -> body velocities, Box2D step and
// contacts, then reward, the task's rows, info, termination (any TIAGo
// contact), truncation (horizon), observation and same-step autoreset.
// prof: null, or the sections' seconds to add to.
void nav_step_range(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, const double* actions, int begin,
                    int end, NavProfile* prof);

// Observation of env e (kNavObsDim floats).
void nav_write_obs(const NavBatch& b, int e, float* obs_row);

// ---- one-env pieces shared by the kernels and the reference

// Linear velocity that moves a body from heading theta along the exact
// unicycle arc of (v, w) over dt when Box2D integrates c += dt * vel: the
// chord of the arc divided by dt, v sinc(w dt / 2) at the mid heading.
// vel: world vx, vy, omega.
void nav_unicycle_chord_velocity(double theta, double v, double w, double dt, double* vel);

// An episode's start from rng: TIAGo's and Fetch's poses (rounded to float,
// Fetch at least room.min_start_separation from TIAGo when 64 draws allow)
// and both goals.
void nav_draw_start(const NavModel& m, Rng& rng, double* tiago_pose, double* fetch_pose, double* goal,
                    double* fetch_goal);

// Fetch's controller at its pose: its command (v, omega) and the velocity
// Box2D will integrate (float-rounded, so ATACOM's xdot is exact). When
// Fetch has arrived it draws a new goal from rng first and returns 1.
int nav_fetch_command(const NavModel& m, Rng& rng, const double* fetch_pose, double* fetch_goal, double* fetch_cmd,
                      double* fetch_vel);

// ---- scalar reference

// One env's state: a row of NavBatch (scratch excluded).
struct NavEnvState {
  double tiago[3], tiago_vel[3], fetch[3], fetch_vel[3], fetch_cmd[2], goal[2], fetch_goal[2], prev_action[2];
  int32_t t = 0;
  double ret = 0.0;
  Rng rng;
};
NavEnvState nav_env_state(const NavBatch& b, int e);

// What one step of one env writes to EnvBuffers, plus the analytic contact
// gaps at the reached state (m; <= 0 is a contact), which tell a caller how
// close to Box2D's float contact threshold a step landed.
struct NavStepOutput {
  float obs[kNavObsDim], final_obs[kNavObsDim];
  float reward = 0, cost = 0, cost_continuous = 0;
  uint8_t terminated = 0, truncated = 0;
  double constraints[kNavConstraints];
  float info[kNavInfoCount];
  double episode_return = 0;   // when terminated or truncated
  int32_t episode_length = 0;  // when terminated or truncated
  double wall_gap = 0, fetch_gap = 0;
};

// The reference of nav_step_range for one env, in plain code and without
// Box2D: the unicycle step integrated in float as Box2D integrates it,
// contacts from the analytic distances (disc to wall faces, disc to disc),
// then reward, rows, info, termination and autoreset as documented in
// docs/envs_nav.md. Advances s.
NavStepOutput nav_step_reference(const NavModel& m, NavEnvState& s, const double* action);

}  // namespace atacom
