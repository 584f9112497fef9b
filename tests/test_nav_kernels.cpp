// The navigation env's parts (envs/nav/nav_kernels.hpp): the range kernel
// against the scalar one-env reference, and the step's terms at scripted
// states.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "envs/nav/nav_env.hpp"

using namespace atacom;

namespace {

struct Tally {
  int steps = 0, compared = 0, near_contact = 0;
  int wall = 0, robot = 0, truncated = 0, fetch_goals = 0, nan = 0, at_goal = 0;
};

// Steps env with the given actions and checks every env's step against
// nav_step_reference from the state before it. Steps whose reached state is
// within 1e-5 m of a contact are not compared: there Box2D's float polygon
// test and the analytic distance may round either way.
void step_and_compare(NavEnv& env, const std::vector<double>& actions, Tally& tally) {
  const int N = env.num_envs();
  std::vector<NavEnvState> before;
  for (int e = 0; e < N; ++e) before.push_back(nav_env_state(env.state(), e));
  env.step(actions.data());
  const EnvBuffers& b = env.buffers();
  const NavBatch& st = env.state();
  const int od = kNavObsDim, ni = kNavInfoCount, k = kNavConstraints;
  for (int e = 0; e < N; ++e) {
    ++tally.steps;
    NavEnvState s = before[size_t(e)];
    const NavStepOutput r = nav_step_reference(env.model(), s, &actions[2 * size_t(e)]);
    if (std::abs(r.wall_gap) < 1e-5 || std::abs(r.fetch_gap) < 1e-5) {
      ++tally.near_contact;
      continue;
    }
    ++tally.compared;
    INFO("env " << e << " t " << before[size_t(e)].t);
    const float* info = &b.info[size_t(ni) * e];
    REQUIRE(b.terminated[e] == r.terminated);
    REQUIRE(b.truncated[e] == r.truncated);
    REQUIRE(info[kNavInfoWallCollision] == r.info[kNavInfoWallCollision]);
    REQUIRE(info[kNavInfoRobotCollision] == r.info[kNavInfoRobotCollision]);
    REQUIRE(info[kNavInfoCollision] == r.info[kNavInfoCollision]);
    REQUIRE(info[kNavInfoFetchGoals] == r.info[kNavInfoFetchGoals]);
    REQUIRE(info[kNavInfoNanAction] == r.info[kNavInfoNanAction]);
    for (int j : {kNavInfoFinalDistance, kNavInfoMeanDistance, kNavInfoFetchDistance})
      REQUIRE(info[j] == Approx(r.info[j]).margin(1e-6));
    if (std::abs(info[kNavInfoFinalDistance] - float(env.config().reward.goal_radius)) > 1e-5f)
      REQUIRE(info[kNavInfoAtGoal] == r.info[kNavInfoAtGoal]);
    REQUIRE(b.reward[e] == Approx(r.reward).epsilon(1e-6).margin(1e-6));
    REQUIRE(b.cost[e] == r.cost);
    REQUIRE(b.cost_continuous[e] == r.cost_continuous);
    for (int j = 0; j < k; ++j) REQUIRE(b.constraints[size_t(k) * e + j] == r.constraints[j]);
    // Observations: the same doubles rounded to float (the pose is Box2D's,
    // bit for bit, on both sides).
    for (int j = 0; j < od; ++j) {
      REQUIRE(b.obs[size_t(od) * e + j] == r.obs[j]);
      REQUIRE(b.final_obs[size_t(od) * e + j] == r.final_obs[j]);
    }
    if (r.terminated || r.truncated) {
      REQUIRE(b.episode_length[e] == r.episode_length);
      REQUIRE(b.episode_return[e] == Approx(r.episode_return).epsilon(1e-12).margin(1e-9));
    }
    // The state after the step (a new episode's start when it ended).
    for (int j = 0; j < 3; ++j) {
      REQUIRE(st.tiago[3 * size_t(e) + j] == s.tiago[j]);
      REQUIRE(st.tiago_vel[3 * size_t(e) + j] == s.tiago_vel[j]);
      REQUIRE(st.fetch[3 * size_t(e) + j] == s.fetch[j]);
      REQUIRE(st.fetch_vel[3 * size_t(e) + j] == s.fetch_vel[j]);
    }
    for (int j = 0; j < 2; ++j) {
      REQUIRE(st.goal[2 * size_t(e) + j] == s.goal[j]);
      REQUIRE(st.fetch_goal[2 * size_t(e) + j] == s.fetch_goal[j]);
      REQUIRE(st.fetch_cmd[2 * size_t(e) + j] == s.fetch_cmd[j]);
      REQUIRE(st.prev_action[2 * size_t(e) + j] == s.prev_action[j]);
    }
    REQUIRE(st.t[e] == s.t);
    REQUIRE(st.ret[e] == Approx(s.ret).epsilon(1e-12).margin(1e-9));
    const Rng::State ra = st.rng[e].state(), rb = s.rng.state();
    REQUIRE(std::equal(std::begin(ra.s), std::end(ra.s), std::begin(rb.s)));

    tally.wall += r.info[kNavInfoWallCollision] > 0;
    tally.robot += r.info[kNavInfoRobotCollision] > 0;
    tally.truncated += r.truncated;
    tally.fetch_goals += r.info[kNavInfoFetchGoals] > 0;
    tally.nan += r.info[kNavInfoNanAction] > 0;
    tally.at_goal += r.info[kNavInfoAtGoal] > 0;
  }
}

}  // namespace

TEST_CASE("nav kernels: the range kernel agrees with the scalar reference, ATACOM off and on", "[nav_env]") {
  NavConfig cfg = default_nav_config();
  cfg.horizon = 150;  // truncations too
  cfg.block = 16;    // several blocks
  const int N = 64;
  for (bool atacom : {false, true}) {
    DYNAMIC_SECTION((atacom ? "ATACOM on" : "ATACOM off")) {
      NavEnv env(cfg, N);
      env.seed(atacom ? 21 : 20);
      const ProjectorModel pm = env.projector_model();
      ProjectorBatch pb(pm, N);
      Rng rng(7, atacom ? 1 : 0);
      // Held commands (redrawn now and then, mostly forward) reach walls and
      // Fetch within an episode; a uniform draw per step only jitters.
      std::vector<double> held(2 * size_t(N)), actions(2 * size_t(N));
      Tally tally;
      for (int step = 0; step < 400; ++step) {
        for (int e = 0; e < N; ++e)
          if (step == 0 || rng.uniform(0.0, 1.0) < 0.05) {
            held[2 * size_t(e)] = rng.uniform(-0.5, 1.2);
            held[2 * size_t(e) + 1] = rng.uniform(-1.2, 1.2);
          }
        if (atacom) {
          // The safe control of alpha, as SafeEnv applies it.
          env.constraint_model(pb, 0, N);
          for (size_t j = 0; j < held.size(); ++j) pb.alpha[j] = std::clamp(held[j], -1.0, 1.0);
          project_range(pm, pb, 0, N, {.store_slack = false, .parallel = false});
          actions = pb.a;
        } else {
          // Past the bounds and sometimes NaN: the kernel clips and counts.
          actions = held;
          for (double& a : actions)
            if (rng.uniform(0.0, 1.0) < 0.005) a = std::numeric_limits<double>::quiet_NaN();
        }
        step_and_compare(env, actions, tally);
      }
      INFO("compared " << tally.compared << " near contact " << tally.near_contact << " wall " << tally.wall
                       << " robot " << tally.robot << " truncated " << tally.truncated << " fetch goals "
                       << tally.fetch_goals << " at goal " << tally.at_goal);
      REQUIRE(tally.near_contact * 1000 < tally.steps);  // almost every step compared
      REQUIRE(tally.truncated > 0);
      REQUIRE(tally.fetch_goals > 0);
      if (!atacom) {
        REQUIRE(tally.wall > 0);   // terminations at walls
        REQUIRE(tally.robot > 0);  // and at the moving Fetch
        REQUIRE(tally.nan > 0);
      }
    }
  }
}

TEST_CASE("nav kernels: the reference integrates the exact unicycle step within float rounding", "[nav_env]") {
  NavEnv env(default_nav_config(), 1);
  const double tp[3] = {0.5, -0.25, 0.3}, fp[3] = {2.0, 1.5, 0.0}, goal[2] = {-2.0, 0.0}, fgoal[2] = {2.0, 1.0};
  env.place(0, tp, fp, goal, fgoal);
  NavEnvState s = nav_env_state(env.state(), 0);
  const double a[2] = {0.8, -0.6};
  nav_step_reference(env.model(), s, a);
  const NavConfig& c = env.config();
  const double v = 0.8 * c.tiago.v_max, w = -0.6 * c.tiago.w_max, th = double(float(0.3)) + w * c.dt;
  REQUIRE(s.tiago[0] == Approx(double(float(0.5)) + v / w * (std::sin(th) - std::sin(double(float(0.3))))).margin(1e-6));
  REQUIRE(s.tiago[1] == Approx(double(float(-0.25)) - v / w * (std::cos(th) - std::cos(double(float(0.3))))).margin(1e-6));
  REQUIRE(s.tiago[2] == Approx(th).margin(1e-6));
}

TEST_CASE("nav env: reward terms at a scripted state", "[nav_env]") {
  NavEnv env(default_nav_config(), 1);
  const double tp[3] = {0.0, 0.0, 0.0}, fp[3] = {2.0, 1.5, 0.0}, fgoal[2] = {2.0, 1.0};
  {  // goal 0.1 m ahead: inside 0.2 m, bonus; action change from 0 to (1, 0)
    const double goal[2] = {0.15, 0.0};
    env.place(0, tp, fp, goal, fgoal);
    const double a[2] = {1.0, 0.0};
    env.step(a);
    const double dist = 0.15 - 1.0 / 30.0;
    const double expect = -dist - 0.0 - 0.1 * 1.0 + 10.0;
    REQUIRE(env.buffers().reward[0] == Approx(expect).epsilon(1e-5));
    REQUIRE(env.buffers().info[kNavInfoAtGoal] == 1.0f);
    REQUIRE(env.buffers().info[kNavInfoFinalDistance] == Approx(dist).epsilon(1e-5));
  }
  {  // goal 2 m behind: full heading penalty |pi| * sigmoid(20 * 1.7) / pi = 1
    const double goal[2] = {-2.0, 0.0};
    env.place(0, tp, fp, goal, fgoal);
    const double a[2] = {0.0, 0.0};
    env.step(a);
    REQUIRE(env.buffers().reward[0] == Approx(-2.0 - 1.0).epsilon(1e-6));
  }
}

TEST_CASE("nav env: NaN actions become 0 and are counted, out-of-range actions are clipped", "[nav_env]") {
  NavEnv env(default_nav_config(), 2);
  const double tp[3] = {0.0, 0.0, 0.0}, fp[3] = {2.0, 1.5, 0.0}, goal[2] = {-2.0, 0.0}, fgoal[2] = {2.0, 1.0};
  env.place(0, tp, fp, goal, fgoal);
  env.place(1, tp, fp, goal, fgoal);
  const double a[4] = {std::nan(""), 5.0, 7.0, -std::numeric_limits<double>::infinity()};
  env.step(a);
  REQUIRE(env.buffers().info[kNavInfoNanAction] == 1.0f);
  REQUIRE(env.buffers().info[kNavInfoCount + kNavInfoNanAction] == 0.0f);
  REQUIRE(env.state().prev_action[0] == 0.0);
  REQUIRE(env.state().prev_action[1] == 1.0);
  REQUIRE(env.state().prev_action[2] == 1.0);
  REQUIRE(env.state().prev_action[3] == -1.0);
  REQUIRE(env.state().tiago[0] == 0.0);
  const double h = M_PI / 180;  // half the turn of one step at omega = -pi/3
  REQUIRE(env.state().tiago[3] == Approx(1.0 / 30.0 * std::sin(h) / h * std::cos(h)).epsilon(1e-6));
}

