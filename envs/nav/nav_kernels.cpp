// Range kernels of the navigation env (envs/nav/nav_kernels.hpp).
#include "envs/nav/nav_kernels.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "envs/nav/fetch_policy.hpp"

namespace atacom {

namespace {

// Round to what Box2D stores.
double to_f(double x) { return static_cast<double>(static_cast<float>(x)); }

double sigmoid(double z) { return 1.0 / (1.0 + std::exp(-z)); }

// After poses and goals are set: bodies, Fetch's command, counters.
void start_episode(const NavModel& m, NavBatch& b, NavWorlds& w, int e) {
  w.place(e, &b.tiago[3 * e], &b.fetch[3 * e]);
  for (int j = 0; j < 3; ++j) b.tiago_vel[3 * e + j] = 0.0;
  b.prev_action[2 * e] = b.prev_action[2 * e + 1] = 0.0;
  b.t[e] = 0;
  b.ret[e] = 0.0;
  nav_fetch_command(m, b.rng[e], &b.fetch[3 * e], &b.fetch_goal[2 * e], &b.fetch_cmd[2 * e], &b.fetch_vel[3 * e]);
  w.set_fetch_velocity(e, &b.fetch_vel[3 * e]);
}

void reset_env(const NavModel& m, NavBatch& b, NavWorlds& w, int e) {
  nav_draw_start(m, b.rng[e], &b.tiago[3 * e], &b.fetch[3 * e], &b.goal[2 * e], &b.fetch_goal[2 * e]);
  start_episode(m, b, w, e);
}

// The task's rows at env e's state into out (constraints, cost_continuous);
// returns the rows' values in c.
void task_rows(const NavModel& m, const NavBatch& b, EnvBuffers& out, int e, double* c) {
  const size_t k = kNavConstraints;
  double jq[3 * kNavConstraints], jx[kNavFetchState * kNavConstraints];
  const double xf[kNavFetchState] = {b.fetch[3 * e], b.fetch[3 * e + 1], b.fetch[3 * e + 2]};
  nav_constraints(m.task_geom, &b.tiago[3 * e], xf, c, jq, jx);
  double worst = 0.0;
  for (size_t r = 0; r < k; ++r) { out.constraints[k * e + r] = c[r]; worst = std::max(worst, c[r]); }
  out.cost_continuous[e] = static_cast<float>(worst);
}

}  // namespace

void nav_unicycle_chord_velocity(double theta, double v, double w, double dt, double* vel) {
  const double half = 0.5 * w * dt;
  const double sinc = std::abs(half) < 1e-4 ? 1.0 - half * half / 6.0 : std::sin(half) / half;
  const double mid = theta + half;
  vel[0] = v * sinc * std::cos(mid);
  vel[1] = v * sinc * std::sin(mid);
  vel[2] = w;
}

void nav_draw_start(const NavModel& m, Rng& rng, double* tp, double* fp, double* goal, double* fetch_goal) {
  const double sx = m.spawn_x, sy = m.spawn_y;
  tp[0] = to_f(rng.uniform(-sx, sx));
  tp[1] = to_f(rng.uniform(-sy, sy));
  tp[2] = to_f(rng.uniform(-M_PI, M_PI));
  goal[0] = rng.uniform(-sx, sx);
  goal[1] = rng.uniform(-sy, sy);
  // Fetch start by rejection; validate() bounds the excluded area, and after
  // 64 draws the farthest candidate is kept so the loop always ends.
  const double sep = m.config.room.min_start_separation;
  double best_d = -1.0, bx = 0.0, by = 0.0;
  for (int tries = 0; tries < 64; ++tries) {
    const double x = to_f(rng.uniform(-sx, sx)), y = to_f(rng.uniform(-sy, sy));
    const double d = std::hypot(x - tp[0], y - tp[1]);
    if (d > best_d) { best_d = d; bx = x; by = y; }
    if (d > sep) break;
  }
  fp[0] = bx;
  fp[1] = by;
  fp[2] = to_f(rng.uniform(-M_PI, M_PI));
  fetch_goal[0] = rng.uniform(-sx, sx);
  fetch_goal[1] = rng.uniform(-sy, sy);
}

int nav_fetch_command(const NavModel& m, Rng& rng, const double* pose, double* goal, double* fetch_cmd,
                      double* fetch_vel) {
  const FetchPolicyParams& fp = m.config.fetch.policy;
  FetchCommand cmd = fetch_command(fp, pose, goal);
  const bool goal_drawn = cmd.arrived;
  if (goal_drawn) {
    goal[0] = rng.uniform(-m.spawn_x, m.spawn_x);
    goal[1] = rng.uniform(-m.spawn_y, m.spawn_y);
    // A goal drawn onto the current pose is accepted: it counts as reached
    // at the next step.
    cmd = fetch_command(fp, pose, goal);
  }
  fetch_cmd[0] = cmd.v;
  fetch_cmd[1] = cmd.w;
  double vel[3];
  nav_unicycle_chord_velocity(pose[2], cmd.v, cmd.w, m.config.dt, vel);
  for (int j = 0; j < 3; ++j) fetch_vel[j] = to_f(vel[j]);
  return goal_drawn ? 1 : 0;
}

void nav_write_obs(const NavBatch& b, int e, float* o) {
  const double* tp = &b.tiago[3 * e];
  const double* tv = &b.tiago_vel[3 * e];
  const double* fp = &b.fetch[3 * e];
  const double* fv = &b.fetch_vel[3 * e];
  o[0] = static_cast<float>(b.goal[2 * e]);
  o[1] = static_cast<float>(b.goal[2 * e + 1]);
  o[2] = static_cast<float>(tp[0]);
  o[3] = static_cast<float>(tp[1]);
  o[4] = static_cast<float>(std::cos(tp[2]));
  o[5] = static_cast<float>(std::sin(tp[2]));
  o[6] = static_cast<float>(tv[0]);
  o[7] = static_cast<float>(tv[1]);
  o[8] = static_cast<float>(tv[2]);
  o[9] = static_cast<float>(fp[0]);
  o[10] = static_cast<float>(fp[1]);
  o[11] = static_cast<float>(std::cos(fp[2]));
  o[12] = static_cast<float>(std::sin(fp[2]));
  o[13] = static_cast<float>(fv[0]);
  o[14] = static_cast<float>(fv[1]);
  o[15] = static_cast<float>(fv[2]);
  o[16] = static_cast<float>(b.prev_action[2 * e]);
  o[17] = static_cast<float>(b.prev_action[2 * e + 1]);
}

void nav_reset_range(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, const uint8_t* mask, int begin,
                     int end) {
  const size_t ni = kNavInfoCount, od = kNavObsDim;
  for (int e = begin; e < end; ++e) {
    if (mask && !mask[e]) continue;
    std::fill_n(&out.info[ni * e], ni, 0.0f);
    reset_env(m, b, w, e);
    float* o = &out.obs[od * e];
    nav_write_obs(b, e, o);
    std::copy_n(o, od, &out.final_obs[od * e]);
    out.reward[e] = 0.0f;
    out.terminated[e] = out.truncated[e] = 0;
    double c[kNavConstraints];
    task_rows(m, b, out, e, c);
    out.cost[e] = 0.0f;  // no step happened
  }
}

void nav_place(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, int e, const double* tiago_pose,
               const double* fetch_pose, const double* goal, const double* fetch_goal) {
  for (int j = 0; j < 3; ++j) {
    b.tiago[3 * e + j] = to_f(tiago_pose[j]);
    b.fetch[3 * e + j] = to_f(fetch_pose[j]);
  }
  for (int j = 0; j < 2; ++j) {
    b.goal[2 * e + j] = goal[j];
    b.fetch_goal[2 * e + j] = fetch_goal[j];
  }
  const size_t ni = kNavInfoCount, od = kNavObsDim;
  std::fill_n(&out.info[ni * e], ni, 0.0f);
  start_episode(m, b, w, e);
  nav_write_obs(b, e, &out.obs[od * e]);
  std::copy_n(&out.obs[od * e], od, &out.final_obs[od * e]);
  out.terminated[e] = out.truncated[e] = 0;
}

void nav_step_range(const NavModel& m, NavBatch& b, NavWorlds& w, EnvBuffers& out, const double* actions, int begin,
                    int end, NavProfile* prof) {
  using clock = std::chrono::steady_clock;
  clock::time_point t0, t1, t2;
  if (prof) t0 = clock::now();
  const NavConfig& cfg = m.config;
  const size_t k = kNavConstraints, ni = kNavInfoCount, od = kNavObsDim;

  // 1. Actions -> body velocities (TIAGo from the action, Fetch from the
  //    command its controller chose at the current state).
  for (int e = begin; e < end; ++e) {
    uint8_t nan = 0;
    for (int j = 0; j < 2; ++j) {
      double a = actions[2 * e + j];
      if (std::isnan(a)) { a = 0.0; nan = 1; }
      b.act[2 * e + j] = std::clamp(a, -1.0, 1.0);
    }
    b.nan[e] = nan;
    double vel[3];
    nav_unicycle_chord_velocity(b.tiago[3 * e + 2], cfg.tiago.v_max * b.act[2 * e],
                                cfg.tiago.w_max * b.act[2 * e + 1], cfg.dt, vel);
    w.set_tiago_velocity(e, vel);
    w.set_fetch_velocity(e, &b.fetch_vel[3 * e]);
  }
  if (prof) t1 = clock::now();

  // 2. Box2D: integrate, then the contacts at the reached poses.
  for (int e = begin; e < end; ++e) w.step(e, &b.hit_wall[e], &b.hit_fetch[e]);
  if (prof) t2 = clock::now();

  // 3. Mirror into the SoA, reward, constraints, Fetch's next command,
  //    observation and same-step autoreset.
  const NavConfig::Reward& rw = cfg.reward;
  for (int e = begin; e < end; ++e) {
    double* tp = &b.tiago[3 * e];
    double* fp = &b.fetch[3 * e];
    w.read(e, tp, fp, &b.tiago_vel[3 * e]);

    const double* a = &b.act[2 * e];
    double* pa = &b.prev_action[2 * e];
    const double ex = b.goal[2 * e] - tp[0], ey = b.goal[2 * e + 1] - tp[1];
    const double dist = std::sqrt(ex * ex + ey * ey);
    const double heading_err = wrap_angle(std::atan2(ey, ex) - tp[2]);
    const bool collided = b.hit_wall[e] || b.hit_fetch[e];
    double r;
    if (collided) {
      r = rw.collision_reward;
    } else {
      r = -rw.distance_weight * dist -
          std::abs(heading_err) * sigmoid(rw.heading_gain * (dist - rw.heading_offset)) / M_PI -
          rw.action_change_weight * std::hypot(a[0] - pa[0], a[1] - pa[1]);
      if (dist < rw.goal_radius) r += rw.goal_bonus;
    }
    pa[0] = a[0];
    pa[1] = a[1];
    b.t[e] += 1;
    b.ret[e] += r;

    // The task's rows (docs/envs_nav.md): ATACOM enforces stricter ones.
    double c[kNavConstraints];
    task_rows(m, b, out, e, c);
    out.cost[e] = step_cost(c, m.spec.constraint_tolerance.data(), int(k), collided);

    float* info = &out.info[ni * e];
    std::fill_n(info, ni, 0.0f);
    info[kNavInfoCollision] = collided ? 1.0f : 0.0f;
    info[kNavInfoWallCollision] = b.hit_wall[e] ? 1.0f : 0.0f;
    info[kNavInfoRobotCollision] = b.hit_fetch[e] ? 1.0f : 0.0f;
    info[kNavInfoFinalDistance] = static_cast<float>(dist);
    info[kNavInfoMeanDistance] = static_cast<float>(dist);
    info[kNavInfoAtGoal] = dist < rw.goal_radius ? 1.0f : 0.0f;
    info[kNavInfoFetchDistance] = static_cast<float>(std::hypot(tp[0] - fp[0], tp[1] - fp[1]));
    info[kNavInfoNanAction] = static_cast<float>(b.nan[e]);

    out.reward[e] = static_cast<float>(r);
    out.terminated[e] = collided ? 1 : 0;
    out.truncated[e] = (!collided && b.t[e] >= cfg.horizon) ? 1 : 0;
    float* obs = &out.obs[od * e];
    float* fin = &out.final_obs[od * e];
    if (out.terminated[e] || out.truncated[e]) {
      nav_write_obs(b, e, fin);
      out.episode_return[e] = b.ret[e];
      out.episode_length[e] = b.t[e];
      reset_env(m, b, w, e);
      nav_write_obs(b, e, obs);
    } else {
      info[kNavInfoFetchGoals] = static_cast<float>(nav_fetch_command(
          m, b.rng[e], &b.fetch[3 * e], &b.fetch_goal[2 * e], &b.fetch_cmd[2 * e], &b.fetch_vel[3 * e]));
      nav_write_obs(b, e, obs);
      std::copy_n(obs, od, fin);
    }
  }
  if (prof) {
    const auto t3 = clock::now();
    prof->box2d += std::chrono::duration<double>(t2 - t1).count();
    prof->env += std::chrono::duration<double>(t1 - t0).count() + std::chrono::duration<double>(t3 - t2).count();
  }
}

}  // namespace atacom
