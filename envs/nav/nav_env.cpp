// NavEnv on Box2D 2.4: one b2World per env, blocks of worlds in parallel.
#include "envs/nav/nav_env.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <istream>
#include <mutex>
#include <ostream>
#include <stdexcept>

#include <box2d/box2d.h>
#include <nlohmann/json.hpp>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "src/core/env_target.hpp"
#include "envs/nav/nav_batch_fields.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

namespace {

// Collision filter categories: Fetch never collides with the walls (its
// controller keeps it inside), so every Box2D contact involves TIAGo.
constexpr uint16 kCatWall = 0x1, kCatTiago = 0x2, kCatFetch = 0x4;

// Box2D registers its contact types in a static table the first time a
// contact is created; do that once on one thread before worlds step in
// parallel.
void warm_up_box2d() {
  static std::once_flag once;
  std::call_once(once, [] {
    b2World w(b2Vec2(0.0f, 0.0f));
    b2BodyDef bd;
    bd.type = b2_dynamicBody;
    b2CircleShape circle;
    circle.m_radius = 1.0f;
    b2Body* a = w.CreateBody(&bd);
    a->CreateFixture(&circle, 1.0f);
    bd.position.Set(0.5f, 0.0f);
    b2Body* b = w.CreateBody(&bd);
    b->CreateFixture(&circle, 1.0f);
    w.Step(0.01f, 1, 1);
  });
}

// Linear velocity that moves a body from heading theta along the exact
// unicycle arc of (v, omega) over dt when Box2D integrates c += dt * vel:
// the chord of the arc divided by dt, v sinc(omega dt / 2) at the mid heading.
void unicycle_chord_velocity(double theta, double v, double w, double dt, double* vel) {
  const double half = 0.5 * w * dt;
  const double sinc = std::abs(half) < 1e-4 ? 1.0 - half * half / 6.0 : std::sin(half) / half;
  const double mid = theta + half;
  vel[0] = v * sinc * std::cos(mid);
  vel[1] = v * sinc * std::sin(mid);
  vel[2] = w;
}

// Round to what Box2D stores.
double to_f(double x) { return static_cast<double>(static_cast<float>(x)); }

double sigmoid(double z) { return 1.0 / (1.0 + std::exp(-z)); }

constexpr uint32_t kTagNav = snapshot_tag("NAV ");


}  // namespace

struct NavEnv::World {
  b2World world{b2Vec2(0.0f, 0.0f)};
  b2Body* walls = nullptr;
  b2Body* tiago = nullptr;
  b2Body* fetch = nullptr;
};

void NavBatch::resize(int n) {
  N = n;
  const size_t s = static_cast<size_t>(n);
  tiago.assign(3 * s, 0.0);
  tiago_vel.assign(3 * s, 0.0);
  fetch.assign(3 * s, 0.0);
  fetch_vel.assign(3 * s, 0.0);
  fetch_cmd.assign(2 * s, 0.0);
  goal.assign(2 * s, 0.0);
  fetch_goal.assign(2 * s, 0.0);
  prev_action.assign(2 * s, 0.0);
  t.assign(s, 0);
  ret.assign(s, 0.0);
  rng.assign(s, Rng());
}

NavEnv::NavEnv(const NavConfig& config, int num_envs) : cfg_(config) {
  validate(cfg_);
  if (num_envs < 1) throw std::invalid_argument("NavEnv: number of envs must be >= 1");
  geom_ = nav_constraint_geometry(cfg_);
  task_geom_ = nav_task_geometry(geom_);
  sys_ = nav_tiago_system(cfg_);

  spec_.name = "nav";
  spec_.obs_dim = kNavObsDim;
  spec_.act_dim = kNavActDim;
  const float rx = static_cast<float>(cfg_.room.x), ry = static_cast<float>(cfg_.room.y);
  const float tv = static_cast<float>(cfg_.tiago.v_max), tw = static_cast<float>(cfg_.tiago.w_max);
  const float fv = static_cast<float>(cfg_.fetch.policy.v_max), fw = static_cast<float>(cfg_.fetch.policy.w_max);
  spec_.obs_high = {rx, ry, rx, ry, 1.0f, 1.0f, tv, tv, tw, rx, ry, 1.0f, 1.0f, fv, fv, fw, 1.0f, 1.0f};
  spec_.obs_low.resize(kNavObsDim);
  for (int j = 0; j < kNavObsDim; ++j) spec_.obs_low[j] = -spec_.obs_high[j];
  spec_.dt = cfg_.dt;
  spec_.horizon = cfg_.horizon;
  spec_.gamma = 0.995;  // the task's discount (reference 4.3.1)
  spec_.num_constraints = kNavConstraints;
  spec_.constraint_tolerance.assign(kNavConstraints, cfg_.constraints.violation_tolerance);
  spec_.constraint_names = {"wall_x_pos", "wall_y_pos", "wall_x_neg", "wall_y_neg", "fetch_clearance"};
  spec_.info_names = {"collision",     "wall_collision", "robot_collision", "final_distance", "mean_distance",
                      "at_goal",       "fetch_distance", "fetch_goals",     "nan_action"};
  spec_.info_reduce = {InfoReduce::Sum,  InfoReduce::Sum,  InfoReduce::Sum,  InfoReduce::Last, InfoReduce::Mean,
                       InfoReduce::Last, InfoReduce::Last, InfoReduce::Sum,  InfoReduce::Sum};
  spec_.cost_events = {"collision"};  // wall or Fetch contact
  spec_.target = cfg_.target;
  check_env_target(spec_);

  buffers_.resize(spec_, num_envs);
  st_.resize(num_envs);
  const size_t n = static_cast<size_t>(num_envs);
  act_.assign(2 * n, 0.0);
  nan_.assign(n, 0);
  hit_wall_.assign(n, 0);
  hit_fetch_.assign(n, 0);
  const int blocks = (num_envs + cfg_.block - 1) / cfg_.block;
  profile_acc_.assign(2 * static_cast<size_t>(blocks), 0.0);

  warm_up_box2d();
  worlds_.resize(n);
  for (int i = 0; i < num_envs; ++i) build_world(i);
  seed(0);
}

NavEnv::~NavEnv() = default;

void NavEnv::build_world(int i) {
  auto w = std::make_unique<World>();
  b2World& world = w->world;
  // Bodies are velocity driven every step: nothing may fall asleep, contacts
  // end the episode (no impulses to carry over), motion per step is far below
  // every shape size (no tunnelling, so no continuous collision).
  world.SetAllowSleeping(false);
  world.SetWarmStarting(false);
  world.SetContinuousPhysics(false);
  world.SetSubStepping(false);

  b2BodyDef wall_def;  // static, at the origin
  w->walls = world.CreateBody(&wall_def);
  // Box2D pads polygons with a skin of b2_polygonRadius; move the boxes out by
  // it so the contact surface is exactly the inner face at +-room.
  const float skin = b2_polygonRadius;
  const float t = static_cast<float>(cfg_.room.wall_thickness);
  const float rx = static_cast<float>(cfg_.room.x), ry = static_cast<float>(cfg_.room.y);
  b2PolygonShape box;
  b2FixtureDef wall_fix;
  wall_fix.shape = &box;
  wall_fix.friction = 0.0f;
  wall_fix.filter.categoryBits = kCatWall;
  wall_fix.filter.maskBits = kCatTiago;
  const float cx = rx + skin + 0.5f * t, cy = ry + skin + 0.5f * t;
  box.SetAsBox(0.5f * t, ry + t, b2Vec2(cx, 0.0f), 0.0f);
  w->walls->CreateFixture(&wall_fix);
  box.SetAsBox(0.5f * t, ry + t, b2Vec2(-cx, 0.0f), 0.0f);
  w->walls->CreateFixture(&wall_fix);
  box.SetAsBox(rx + t, 0.5f * t, b2Vec2(0.0f, cy), 0.0f);
  w->walls->CreateFixture(&wall_fix);
  box.SetAsBox(rx + t, 0.5f * t, b2Vec2(0.0f, -cy), 0.0f);
  w->walls->CreateFixture(&wall_fix);

  b2BodyDef disc_def;
  disc_def.type = b2_dynamicBody;
  disc_def.allowSleep = false;
  disc_def.linearDamping = 0.0f;
  disc_def.angularDamping = 0.0f;
  disc_def.gravityScale = 0.0f;
  b2CircleShape circle;
  b2FixtureDef disc_fix;
  disc_fix.shape = &circle;
  disc_fix.density = 1.0f;
  disc_fix.friction = 0.0f;

  circle.m_radius = static_cast<float>(cfg_.tiago.radius);
  disc_fix.filter.categoryBits = kCatTiago;
  disc_fix.filter.maskBits = kCatWall | kCatFetch;
  w->tiago = world.CreateBody(&disc_def);
  w->tiago->CreateFixture(&disc_fix);

  circle.m_radius = static_cast<float>(cfg_.fetch.radius);
  disc_fix.filter.categoryBits = kCatFetch;
  disc_fix.filter.maskBits = kCatTiago;
  w->fetch = world.CreateBody(&disc_def);
  w->fetch->CreateFixture(&disc_fix);

  // Box2D's block allocator takes a 16 KB chunk for contacts the first time
  // a world creates one. Overlap TIAGo with a wall and with Fetch once and
  // let a zero-length step (no integration) create the contacts, so no later
  // step allocates; the episode start moves the bodies apart and the next
  // step returns the contacts to the free list.
  const float rt = static_cast<float>(cfg_.tiago.radius), rf = static_cast<float>(cfg_.fetch.radius);
  w->tiago->SetTransform(b2Vec2(rx - 0.5f * rt, 0.0f), 0.0f);
  w->fetch->SetTransform(b2Vec2(rx - 1.5f * rt - 0.5f * rf, 0.0f), 0.0f);
  world.Step(0.0f, 1, 1);

  worlds_[i] = std::move(w);
}

// ---------------------------------------------------------------- episodes

int NavEnv::update_fetch_command(int i) {
  const FetchPolicyParams& fp = cfg_.fetch.policy;
  const double* pose = &st_.fetch[3 * i];
  double* goal = &st_.fetch_goal[2 * i];
  FetchCommand cmd = fetch_command(fp, pose, goal);
  const bool goal_drawn = cmd.arrived;
  if (goal_drawn) {
    const double sx = cfg_.room.spawn_fraction * cfg_.room.x, sy = cfg_.room.spawn_fraction * cfg_.room.y;
    goal[0] = st_.rng[i].uniform(-sx, sx);
    goal[1] = st_.rng[i].uniform(-sy, sy);
    // A goal drawn onto the current pose is accepted: it counts as reached
    // at the next step.
    cmd = fetch_command(fp, pose, goal);
  }
  st_.fetch_cmd[2 * i] = cmd.v;
  st_.fetch_cmd[2 * i + 1] = cmd.w;
  // Store what Box2D will integrate (float), so ATACOM's xdot is exact.
  double vel[3];
  unicycle_chord_velocity(pose[2], cmd.v, cmd.w, cfg_.dt, vel);
  for (int j = 0; j < 3; ++j) st_.fetch_vel[3 * i + j] = to_f(vel[j]);
  return goal_drawn ? 1 : 0;
}

void NavEnv::start_episode(int i) {
  World& w = *worlds_[i];
  const double* tp = &st_.tiago[3 * i];
  const double* fp = &st_.fetch[3 * i];
  w.tiago->SetTransform(b2Vec2(static_cast<float>(tp[0]), static_cast<float>(tp[1])), static_cast<float>(tp[2]));
  w.fetch->SetTransform(b2Vec2(static_cast<float>(fp[0]), static_cast<float>(fp[1])), static_cast<float>(fp[2]));
  w.tiago->SetLinearVelocity(b2Vec2(0.0f, 0.0f));
  w.tiago->SetAngularVelocity(0.0f);
  for (int j = 0; j < 3; ++j) st_.tiago_vel[3 * i + j] = 0.0;
  st_.prev_action[2 * i] = st_.prev_action[2 * i + 1] = 0.0;
  st_.t[i] = 0;
  st_.ret[i] = 0.0;
  update_fetch_command(i);
  w.fetch->SetLinearVelocity(
      b2Vec2(static_cast<float>(st_.fetch_vel[3 * i]), static_cast<float>(st_.fetch_vel[3 * i + 1])));
  w.fetch->SetAngularVelocity(static_cast<float>(st_.fetch_vel[3 * i + 2]));
}

void NavEnv::reset_env(int i) {
  Rng& rng = st_.rng[i];
  const double sx = cfg_.room.spawn_fraction * cfg_.room.x, sy = cfg_.room.spawn_fraction * cfg_.room.y;
  double* tp = &st_.tiago[3 * i];
  double* fp = &st_.fetch[3 * i];
  tp[0] = to_f(rng.uniform(-sx, sx));
  tp[1] = to_f(rng.uniform(-sy, sy));
  tp[2] = to_f(rng.uniform(-M_PI, M_PI));
  st_.goal[2 * i] = rng.uniform(-sx, sx);
  st_.goal[2 * i + 1] = rng.uniform(-sy, sy);
  // Fetch start by rejection; validate() bounds the excluded area, and after
  // 64 draws the farthest candidate is kept so the loop always ends.
  const double sep = cfg_.room.min_start_separation;
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
  st_.fetch_goal[2 * i] = rng.uniform(-sx, sx);
  st_.fetch_goal[2 * i + 1] = rng.uniform(-sy, sy);
  start_episode(i);
}

void NavEnv::write_obs(int i, float* o) const {
  const double* tp = &st_.tiago[3 * i];
  const double* tv = &st_.tiago_vel[3 * i];
  const double* fp = &st_.fetch[3 * i];
  const double* fv = &st_.fetch_vel[3 * i];
  o[0] = static_cast<float>(st_.goal[2 * i]);
  o[1] = static_cast<float>(st_.goal[2 * i + 1]);
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
  o[16] = static_cast<float>(st_.prev_action[2 * i]);
  o[17] = static_cast<float>(st_.prev_action[2 * i + 1]);
}

void NavEnv::seed(uint64_t seed) {
  for (int i = 0; i < st_.N; ++i) st_.rng[i].reseed(seed, static_cast<uint64_t>(i));
  reset(nullptr);
}

void NavEnv::reset(const uint8_t* mask) {
  const int N = st_.N;
  const size_t k = kNavConstraints, ni = kNavInfoCount, od = kNavObsDim;
  parallel_blocks(N, cfg_.block, [&](int64_t lo, int64_t hi) {
    for (int i = static_cast<int>(lo); i < static_cast<int>(hi); ++i) {
      if (mask && !mask[i]) continue;
      std::fill_n(&buffers_.info[ni * i], ni, 0.0f);
      reset_env(i);
      float* o = &buffers_.obs[od * i];
      write_obs(i, o);
      std::copy_n(o, od, &buffers_.final_obs[od * i]);
      buffers_.reward[i] = 0.0f;
      buffers_.terminated[i] = buffers_.truncated[i] = 0;
      double c[kNavConstraints], jq[3 * kNavConstraints], jx[kNavFetchState * kNavConstraints];
      const double xf[kNavFetchState] = {st_.fetch[3 * i], st_.fetch[3 * i + 1], st_.fetch[3 * i + 2]};
      nav_constraints(task_geom_, &st_.tiago[3 * i], xf, c, jq, jx);
      double worst = 0.0;
      for (size_t r = 0; r < k; ++r) { buffers_.constraints[k * i + r] = c[r]; worst = std::max(worst, c[r]); }
      buffers_.cost_continuous[i] = static_cast<float>(worst);
      buffers_.cost[i] = 0.0f;  // no step happened
    }
  });
}

void NavEnv::place(int i, const double* tiago_pose, const double* fetch_pose, const double* goal,
                   const double* fetch_goal) {
  if (i < 0 || i >= st_.N) throw std::out_of_range("NavEnv::place: env index out of range");
  for (int j = 0; j < 3; ++j) {
    st_.tiago[3 * i + j] = to_f(tiago_pose[j]);
    st_.fetch[3 * i + j] = to_f(fetch_pose[j]);
  }
  for (int j = 0; j < 2; ++j) {
    st_.goal[2 * i + j] = goal[j];
    st_.fetch_goal[2 * i + j] = fetch_goal[j];
  }
  const size_t ni = kNavInfoCount, od = kNavObsDim;
  std::fill_n(&buffers_.info[ni * i], ni, 0.0f);
  start_episode(i);
  write_obs(i, &buffers_.obs[od * i]);
  std::copy_n(&buffers_.obs[od * i], od, &buffers_.final_obs[od * i]);
  buffers_.terminated[i] = buffers_.truncated[i] = 0;
}

// ---------------------------------------------------------------- stepping

void NavEnv::step(const double* actions) {
  parallel_blocks(st_.N, cfg_.block, [&](int64_t lo, int64_t hi) {
    step_block(actions, static_cast<int>(lo), static_cast<int>(hi), static_cast<int>(lo / cfg_.block));
  });
}

void NavEnv::step_block(const double* actions, int lo, int hi, int block_index) {
  using clock = std::chrono::steady_clock;
  const bool prof = profiling_;
  clock::time_point t0, t1, t2;
  if (prof) t0 = clock::now();
  const double dt = cfg_.dt;
  const float dtf = static_cast<float>(dt);
  const size_t k = kNavConstraints, ni = kNavInfoCount, od = kNavObsDim;

  // 1. Actions -> body velocities (TIAGo from the action, Fetch from the
  //    command its controller chose at the current state).
  for (int i = lo; i < hi; ++i) {
    uint8_t nan = 0;
    for (int j = 0; j < 2; ++j) {
      double a = actions[2 * i + j];
      if (std::isnan(a)) { a = 0.0; nan = 1; }
      act_[2 * i + j] = std::clamp(a, -1.0, 1.0);
    }
    nan_[i] = nan;
    World& w = *worlds_[i];
    double vel[3];
    unicycle_chord_velocity(st_.tiago[3 * i + 2], cfg_.tiago.v_max * act_[2 * i], cfg_.tiago.w_max * act_[2 * i + 1],
                            dt, vel);
    w.tiago->SetLinearVelocity(b2Vec2(static_cast<float>(vel[0]), static_cast<float>(vel[1])));
    w.tiago->SetAngularVelocity(static_cast<float>(vel[2]));
    w.fetch->SetLinearVelocity(
        b2Vec2(static_cast<float>(st_.fetch_vel[3 * i]), static_cast<float>(st_.fetch_vel[3 * i + 1])));
    w.fetch->SetAngularVelocity(static_cast<float>(st_.fetch_vel[3 * i + 2]));
  }
  if (prof) t1 = clock::now();

  // 2. Box2D: integrate, then query the contact pairs at the reached poses.
  //    Step() collides before it integrates, so its own touching flags
  //    describe the previous poses; Evaluate() on the broad-phase pairs gives
  //    the manifolds at the new ones.
  for (int i = lo; i < hi; ++i) {
    World& w = *worlds_[i];
    w.world.Step(dtf, cfg_.box2d.velocity_iterations, cfg_.box2d.position_iterations);
    uint8_t wall = 0, robot = 0;
    for (b2Contact* c = w.world.GetContactList(); c; c = c->GetNext()) {
      b2Body* a = c->GetFixtureA()->GetBody();
      b2Body* b = c->GetFixtureB()->GetBody();
      b2Manifold m;
      c->Evaluate(&m, a->GetTransform(), b->GetTransform());
      if (m.pointCount == 0) continue;
      if (a == w.walls || b == w.walls) wall = 1;
      else robot = 1;
    }
    hit_wall_[i] = wall;
    hit_fetch_[i] = robot;
  }
  if (prof) t2 = clock::now();

  // 3. Mirror into the SoA, reward, constraints, Fetch's next command,
  //    observation and same-step autoreset.
  const NavConfig::Reward& rw = cfg_.reward;
  for (int i = lo; i < hi; ++i) {
    World& w = *worlds_[i];
    double* tp = &st_.tiago[3 * i];
    double* fp = &st_.fetch[3 * i];
    const b2Vec2 pt = w.tiago->GetPosition(), pf = w.fetch->GetPosition(), vt = w.tiago->GetLinearVelocity();
    tp[0] = pt.x;
    tp[1] = pt.y;
    tp[2] = w.tiago->GetAngle();
    fp[0] = pf.x;
    fp[1] = pf.y;
    fp[2] = w.fetch->GetAngle();
    st_.tiago_vel[3 * i] = vt.x;
    st_.tiago_vel[3 * i + 1] = vt.y;
    st_.tiago_vel[3 * i + 2] = w.tiago->GetAngularVelocity();

    const double* a = &act_[2 * i];
    double* pa = &st_.prev_action[2 * i];
    const double ex = st_.goal[2 * i] - tp[0], ey = st_.goal[2 * i + 1] - tp[1];
    const double dist = std::sqrt(ex * ex + ey * ey);
    const double heading_err = wrap_angle(std::atan2(ey, ex) - tp[2]);
    const bool collided = hit_wall_[i] || hit_fetch_[i];
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
    st_.t[i] += 1;
    st_.ret[i] += r;

    // The task's rows (docs/envs_nav.md): ATACOM enforces stricter ones.
    double c[kNavConstraints], jq[3 * kNavConstraints], jx[kNavFetchState * kNavConstraints];
    const double xf[kNavFetchState] = {fp[0], fp[1], fp[2]};
    nav_constraints(task_geom_, tp, xf, c, jq, jx);
    double worst = 0.0;
    for (size_t j = 0; j < k; ++j) { buffers_.constraints[k * i + j] = c[j]; worst = std::max(worst, c[j]); }
    buffers_.cost_continuous[i] = static_cast<float>(worst);
    buffers_.cost[i] = step_cost(c, spec_.constraint_tolerance.data(), int(k), collided);

    float* info = &buffers_.info[ni * i];
    std::fill_n(info, ni, 0.0f);
    info[kNavInfoCollision] = collided ? 1.0f : 0.0f;
    info[kNavInfoWallCollision] = hit_wall_[i] ? 1.0f : 0.0f;
    info[kNavInfoRobotCollision] = hit_fetch_[i] ? 1.0f : 0.0f;
    info[kNavInfoFinalDistance] = static_cast<float>(dist);
    info[kNavInfoMeanDistance] = static_cast<float>(dist);
    info[kNavInfoAtGoal] = dist < rw.goal_radius ? 1.0f : 0.0f;
    info[kNavInfoFetchDistance] = static_cast<float>(std::hypot(tp[0] - fp[0], tp[1] - fp[1]));
    info[kNavInfoNanAction] = static_cast<float>(nan_[i]);

    buffers_.reward[i] = static_cast<float>(r);
    buffers_.terminated[i] = collided ? 1 : 0;
    buffers_.truncated[i] = (!collided && st_.t[i] >= cfg_.horizon) ? 1 : 0;
    float* obs = &buffers_.obs[od * i];
    float* fin = &buffers_.final_obs[od * i];
    if (buffers_.terminated[i] || buffers_.truncated[i]) {
      write_obs(i, fin);
      buffers_.episode_return[i] = st_.ret[i];
      buffers_.episode_length[i] = st_.t[i];
      reset_env(i);
      write_obs(i, obs);
    } else {
      info[kNavInfoFetchGoals] = static_cast<float>(update_fetch_command(i));
      write_obs(i, obs);
      std::copy_n(obs, od, fin);
    }
  }
  if (prof) {
    const auto t3 = clock::now();
    profile_acc_[2 * block_index] += std::chrono::duration<double>(t2 - t1).count();
    profile_acc_[2 * block_index + 1] +=
        std::chrono::duration<double>(t1 - t0).count() + std::chrono::duration<double>(t3 - t2).count();
  }
}

// ---------------------------------------------------------------- profiling

std::vector<std::string> NavEnv::profile_sections() const { return {"box2d", "env"}; }

void NavEnv::set_profiling(bool on) {
  profiling_ = on;
  if (on) std::fill(profile_acc_.begin(), profile_acc_.end(), 0.0);
}

std::vector<double> NavEnv::profile_seconds() const {
  std::vector<double> s(2, 0.0);
  for (size_t b = 0; b < profile_acc_.size() / 2; ++b) {
    s[0] += profile_acc_[2 * b];
    s[1] += profile_acc_[2 * b + 1];
  }
  return s;
}

// ---------------------------------------------------------------- ATACOM

ProjectorModel NavEnv::projector_model() const {
  const int k = kNavConstraints;
  ProjectorModel m = default_projector_model(3, 2, k, kNavFetchState);
  const SlackType slack = parse_slack_type(cfg_.constraints.slack);
  m.slack.assign(k, slack);
  m.beta = {cfg_.constraints.wall_beta, cfg_.constraints.wall_beta, cfg_.constraints.wall_beta,
            cfg_.constraints.wall_beta, cfg_.constraints.fetch_beta};
  m.tol = {cfg_.constraints.wall_tol, cfg_.constraints.wall_tol, cfg_.constraints.wall_tol,
           cfg_.constraints.wall_tol, cfg_.constraints.fetch_tol};
  m.equality.assign(k, 0);
  m.K_c = 1.0 / cfg_.dt;
  m.basis = parse_basis_type(cfg_.constraints.basis);
  // The per-component clip of a correction outside the box, not the
  // default correction-first scaling: against the moving Fetch one row
  // dominates, and the clip keeps both controls at their limits (closer to
  // the fastest retreat) where scaling shrinks the smaller one. Measured
  // with random actions, 1e7 steps, seed 777001 (issue 31, docs/results.md):
  // 892 violation steps per 1e6 with the clip, 1020 with scaling.
  m.bounds = BoundRule::TangentScale;
  m.g_form = GForm::Dense;
  m.has_drift = false;
  m.validate();
  return m;
}

void NavEnv::constraint_model(ProjectorBatch& pb, int begin, int end) const {
  nav_constraint_model(geom_, sys_, st_.tiago.data(), st_.fetch.data(), st_.fetch_vel.data(), pb, begin, end);
}

// ---------------------------------------------------------------- snapshots

// Snapshot (src/core/snapshot.hpp): HEAD, NAVS (the batch and its
// streams, envs/nav/nav_batch_fields.hpp), BUFS; read into copies first so
// a refused stream leaves the env untouched.
void NavEnv::save_state(std::ostream& out) const {
  nlohmann::json j;
  to_json(j, cfg_);
  SnapshotWriter w(kTagNav, "nav");
  write_head_section(w, st_.N, snapshot_fingerprint(j.dump()));
  write_fields<NavStateFields>(w.section(NavStateFields::kTag), st_);
  write_buffers_section(w, buffers_);
  w.finish(out);
}

void NavEnv::load_state(std::istream& in) {
  nlohmann::json j;
  to_json(j, cfg_);
  SnapshotReader r(in, kTagNav, "nav");
  const int N = st_.N;
  read_head_section(r, N, snapshot_fingerprint(j.dump()));
  NavBatch s;
  s.resize(N);
  read_fields<NavStateFields>(r.section(NavStateFields::kTag, NavStateFields::kName), s);
  EnvBuffers b = buffers_;
  read_buffers_section(r, b);
  r.finish();
  st_ = std::move(s);
  buffers_.copy_values_from(b);
  // Rebuild every world from the SoA: the bodies' poses and velocities are the
  // only Box2D state a step depends on (no touching contact survives a step,
  // warm starting and sleeping are off).
  for (int i = 0; i < N; ++i) {
    build_world(i);
    World& w = *worlds_[i];
    const double* tp = &st_.tiago[3 * i];
    const double* fp = &st_.fetch[3 * i];
    w.tiago->SetTransform(b2Vec2(static_cast<float>(tp[0]), static_cast<float>(tp[1])), static_cast<float>(tp[2]));
    w.fetch->SetTransform(b2Vec2(static_cast<float>(fp[0]), static_cast<float>(fp[1])), static_cast<float>(fp[2]));
  }
}

}  // namespace atacom
