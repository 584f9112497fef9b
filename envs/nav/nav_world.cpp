// NavWorlds: the Box2D 2.4 worlds of the navigation env, one per env.
#include "envs/nav/nav_world.hpp"

#include <mutex>

#include <box2d/box2d.h>

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

}  // namespace

struct NavWorlds::World {
  b2World world{b2Vec2(0.0f, 0.0f)};
  b2Body* walls = nullptr;
  b2Body* tiago = nullptr;
  b2Body* fetch = nullptr;
};

NavWorlds::NavWorlds(const NavConfig& c, int n) : cfg_(c) {
  warm_up_box2d();
  worlds_.resize(static_cast<size_t>(n));
  for (int e = 0; e < n; ++e) rebuild(e);
}

NavWorlds::~NavWorlds() = default;

void NavWorlds::rebuild(int e) {
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

  worlds_[e] = std::move(w);
}

void NavWorlds::place(int e, const double* tiago_pose, const double* fetch_pose) {
  World& w = *worlds_[e];
  const double* tp = tiago_pose;
  const double* fp = fetch_pose;
  w.tiago->SetTransform(b2Vec2(static_cast<float>(tp[0]), static_cast<float>(tp[1])), static_cast<float>(tp[2]));
  w.fetch->SetTransform(b2Vec2(static_cast<float>(fp[0]), static_cast<float>(fp[1])), static_cast<float>(fp[2]));
  w.tiago->SetLinearVelocity(b2Vec2(0.0f, 0.0f));
  w.tiago->SetAngularVelocity(0.0f);
}

void NavWorlds::set_tiago_velocity(int e, const double* vel) {
  World& w = *worlds_[e];
  w.tiago->SetLinearVelocity(b2Vec2(static_cast<float>(vel[0]), static_cast<float>(vel[1])));
  w.tiago->SetAngularVelocity(static_cast<float>(vel[2]));
}

void NavWorlds::set_fetch_velocity(int e, const double* vel) {
  World& w = *worlds_[e];
  w.fetch->SetLinearVelocity(b2Vec2(static_cast<float>(vel[0]), static_cast<float>(vel[1])));
  w.fetch->SetAngularVelocity(static_cast<float>(vel[2]));
}

// Step() collides before it integrates, so its own touching flags describe
// the previous poses; Evaluate() on the broad-phase pairs gives the
// manifolds at the new ones.
void NavWorlds::step(int e, uint8_t* hit_wall, uint8_t* hit_fetch) {
  World& w = *worlds_[e];
  w.world.Step(static_cast<float>(cfg_.dt), cfg_.box2d.velocity_iterations, cfg_.box2d.position_iterations);
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
  *hit_wall = wall;
  *hit_fetch = robot;
}

void NavWorlds::read(int e, double* tiago_pose, double* fetch_pose, double* tiago_vel) const {
  const World& w = *worlds_[e];
  const b2Vec2 pt = w.tiago->GetPosition(), pf = w.fetch->GetPosition(), vt = w.tiago->GetLinearVelocity();
  tiago_pose[0] = pt.x;
  tiago_pose[1] = pt.y;
  tiago_pose[2] = w.tiago->GetAngle();
  fetch_pose[0] = pf.x;
  fetch_pose[1] = pf.y;
  fetch_pose[2] = w.fetch->GetAngle();
  tiago_vel[0] = vt.x;
  tiago_vel[1] = vt.y;
  tiago_vel[2] = w.tiago->GetAngularVelocity();
}

}  // namespace atacom
