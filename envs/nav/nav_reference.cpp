// Scalar reference of the navigation env's step (envs/nav/nav_kernels.hpp):
// one env, plain code, no Box2D. The build compiles this file without FMA
// contraction (CMakeLists.txt) because it reproduces Box2D's float position
// update, which the system library computes without FMAs.
#include <algorithm>
#include <cmath>

#include "envs/nav/nav_kernels.hpp"

namespace atacom {

namespace {

void write_obs(const NavEnvState& s, float* o) {
  const float obs[kNavObsDim] = {
      float(s.goal[0]),         float(s.goal[1]),         // goal
      float(s.tiago[0]),        float(s.tiago[1]),        // TIAGo position
      float(std::cos(s.tiago[2])), float(std::sin(s.tiago[2])),
      float(s.tiago_vel[0]),    float(s.tiago_vel[1]),    float(s.tiago_vel[2]),
      float(s.fetch[0]),        float(s.fetch[1]),        // Fetch position
      float(std::cos(s.fetch[2])), float(std::sin(s.fetch[2])),
      float(s.fetch_vel[0]),    float(s.fetch_vel[1]),    float(s.fetch_vel[2]),
      float(s.prev_action[0]),  float(s.prev_action[1])};
  std::copy_n(obs, kNavObsDim, o);
}

void start_episode(const NavModel& m, NavEnvState& s) {
  std::fill_n(s.tiago_vel, 3, 0.0);
  std::fill_n(s.prev_action, 2, 0.0);
  s.t = 0;
  s.ret = 0.0;
  nav_fetch_command(m, s.rng, s.fetch, s.fetch_goal, s.fetch_cmd, s.fetch_vel);
}

// Box2D's update of a body that no contact pushes: c += h v, a += h omega,
// in float (velocities as set, damping and gravity zero).
void box2d_integrate(double* pose, const double* vel, double dt) {
  const float h = float(dt);
  pose[0] = double(float(pose[0]) + h * float(vel[0]));
  pose[1] = double(float(pose[1]) + h * float(vel[1]));
  pose[2] = double(float(pose[2]) + h * float(vel[2]));
}

}  // namespace

NavEnvState nav_env_state(const NavBatch& b, int e) {
  NavEnvState s;
  std::copy_n(&b.tiago[3 * e], 3, s.tiago);
  std::copy_n(&b.tiago_vel[3 * e], 3, s.tiago_vel);
  std::copy_n(&b.fetch[3 * e], 3, s.fetch);
  std::copy_n(&b.fetch_vel[3 * e], 3, s.fetch_vel);
  std::copy_n(&b.fetch_cmd[2 * e], 2, s.fetch_cmd);
  std::copy_n(&b.goal[2 * e], 2, s.goal);
  std::copy_n(&b.fetch_goal[2 * e], 2, s.fetch_goal);
  std::copy_n(&b.prev_action[2 * e], 2, s.prev_action);
  s.t = b.t[e];
  s.ret = b.ret[e];
  s.rng = b.rng[e];
  return s;
}

NavStepOutput nav_step_reference(const NavModel& m, NavEnvState& s, const double* action) {
  const NavConfig& cfg = m.config;
  NavStepOutput out;
  std::fill_n(out.info, kNavInfoCount, 0.0f);

  // The action as applied: NaN -> 0 (counted), clipped to [-1, 1].
  double a[2];
  bool nan = false;
  for (int j = 0; j < 2; ++j) {
    nan = nan || std::isnan(action[j]);
    a[j] = std::isnan(action[j]) ? 0.0 : std::clamp(action[j], -1.0, 1.0);
  }

  // Both bodies move on their unicycle chords: TIAGo with the action, Fetch
  // with the command its controller chose at the previous state.
  double tiago_vel[3];
  nav_unicycle_chord_velocity(s.tiago[2], cfg.tiago.v_max * a[0], cfg.tiago.w_max * a[1], cfg.dt, tiago_vel);
  for (int j = 0; j < 3; ++j) s.tiago_vel[j] = double(float(tiago_vel[j]));
  box2d_integrate(s.tiago, s.tiago_vel, cfg.dt);
  box2d_integrate(s.fetch, s.fetch_vel, cfg.dt);

  // Contacts at the reached state: TIAGo's disc against the four inner wall
  // faces and against Fetch's disc (touching counts).
  const double x = s.tiago[0], y = s.tiago[1];
  out.wall_gap = std::min(cfg.room.x - std::abs(x), cfg.room.y - std::abs(y)) - cfg.tiago.radius;
  out.fetch_gap = std::hypot(x - s.fetch[0], y - s.fetch[1]) - (cfg.tiago.radius + cfg.fetch.radius);
  const bool hit_wall = out.wall_gap <= 0.0, hit_fetch = out.fetch_gap <= 0.0;
  const bool collided = hit_wall || hit_fetch;

  // Reward (docs/envs_nav.md).
  const NavConfig::Reward& rw = cfg.reward;
  const double dist = std::hypot(s.goal[0] - x, s.goal[1] - y);
  double r = rw.collision_reward;
  if (!collided) {
    const double heading_err = wrap_angle(std::atan2(s.goal[1] - y, s.goal[0] - x) - s.tiago[2]);
    const double heading_weight = 1.0 / (1.0 + std::exp(-rw.heading_gain * (dist - rw.heading_offset)));
    r = -rw.distance_weight * dist - std::abs(heading_err) * heading_weight / M_PI -
        rw.action_change_weight * std::hypot(a[0] - s.prev_action[0], a[1] - s.prev_action[1]);
    if (dist < rw.goal_radius) r += rw.goal_bonus;
  }
  s.prev_action[0] = a[0];
  s.prev_action[1] = a[1];
  s.t += 1;
  s.ret += r;
  out.reward = float(r);

  // The task's rows at the reached state, and the step's costs.
  double jq[3 * kNavConstraints], jx[kNavFetchState * kNavConstraints];
  nav_constraints(m.task_geom, s.tiago, s.fetch, out.constraints, jq, jx);
  double worst = 0.0;
  bool violated = false;
  for (int j = 0; j < kNavConstraints; ++j) {
    worst = std::max(worst, out.constraints[j]);
    violated = violated || out.constraints[j] > m.spec.constraint_tolerance[size_t(j)];
  }
  out.cost_continuous = float(worst);
  out.cost = (violated || collided) ? 1.0f : 0.0f;

  out.info[kNavInfoCollision] = collided;
  out.info[kNavInfoWallCollision] = hit_wall;
  out.info[kNavInfoRobotCollision] = hit_fetch;
  out.info[kNavInfoFinalDistance] = float(dist);
  out.info[kNavInfoMeanDistance] = float(dist);
  out.info[kNavInfoAtGoal] = dist < rw.goal_radius;
  out.info[kNavInfoFetchDistance] = float(std::hypot(x - s.fetch[0], y - s.fetch[1]));
  out.info[kNavInfoNanAction] = nan;

  // A contact ends the episode, the horizon truncates it; either way the
  // next episode starts in the same step.
  out.terminated = collided;
  out.truncated = !collided && s.t >= cfg.horizon;
  if (out.terminated || out.truncated) {
    write_obs(s, out.final_obs);
    out.episode_return = s.ret;
    out.episode_length = s.t;
    nav_draw_start(m, s.rng, s.tiago, s.fetch, s.goal, s.fetch_goal);
    start_episode(m, s);
    write_obs(s, out.obs);
  } else {
    // Fetch's controller picks the next command (and maybe a new goal) at
    // the reached state; the observation shows the velocity it will move with.
    out.info[kNavInfoFetchGoals] = float(nav_fetch_command(m, s.rng, s.fetch, s.fetch_goal, s.fetch_cmd, s.fetch_vel));
    write_obs(s, out.obs);
    std::copy_n(out.obs, kNavObsDim, out.final_obs);
  }
  return out;
}

}  // namespace atacom
