// NavConfig: default factory, validation and strict JSON.
#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "envs/nav/nav_env.hpp"
#include "atacom/projector.hpp"
#include "src/core/config_fields.hpp"
#include "src/core/config_json.hpp"
#include "src/core/env_target.hpp"
#include "src/core/limits.hpp"

namespace atacom {

NavConfig default_nav_config() {
  NavConfig c;
  c.fetch.policy = default_fetch_policy_params();
  return c;
}

namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("config: env." + what);
}

bool pos(double x) { return std::isfinite(x) && x > 0.0; }

}  // namespace

void validate(const NavConfig& c) {
  require(pos(c.dt), "dt must be finite and > 0");
  require(c.horizon >= 1, "horizon must be >= 1");
  require(c.block >= 1, "block must be >= 1");
  require(pos(c.room.x) && pos(c.room.y), "room.x and room.y must be > 0");
  require(pos(c.room.wall_thickness), "room.wall_thickness must be > 0");
  require(pos(c.tiago.radius) && pos(c.fetch.radius), "tiago.radius and fetch.radius must be > 0");
  require(pos(c.tiago.v_max) && pos(c.tiago.w_max), "tiago.v_max and tiago.w_max must be > 0");
  require(pos(c.room.spawn_fraction) && c.room.spawn_fraction <= 1.0, "room.spawn_fraction must be in (0, 1]");
  // Every sampled start must be free of walls and inside the wall constraints.
  const double sx = c.room.spawn_fraction * c.room.x, sy = c.room.spawn_fraction * c.room.y;
  const double reach = std::max(c.tiago.radius + c.constraints.wall_margin, c.fetch.radius);
  require(sx + reach < c.room.x && sy + reach < c.room.y,
          "spawn area (spawn_fraction * room) plus the robot radius and wall margin must fit inside the room");
  // Every start must satisfy the clearance row.
  require(std::isfinite(c.room.min_start_separation) &&
              c.room.min_start_separation > c.tiago.radius + c.fetch.radius + c.constraints.fetch_margin,
          "room.min_start_separation must exceed tiago.radius + fetch.radius + constraints.fetch_margin");
  // Keep rejection sampling of the Fetch start cheap: the excluded disc may
  // cover at most a quarter of the spawn rectangle.
  require(M_PI * c.room.min_start_separation * c.room.min_start_separation <= 0.25 * (4.0 * sx * sy),
          "room.min_start_separation is too large for the spawn area");
  validate(c.fetch.policy);
  require(std::isfinite(c.reward.distance_weight) && c.reward.distance_weight >= 0.0,
          "reward.distance_weight must be >= 0");
  require(std::isfinite(c.reward.heading_gain) && std::isfinite(c.reward.heading_offset),
          "reward.heading_gain and reward.heading_offset must be finite");
  require(std::isfinite(c.reward.action_change_weight) && c.reward.action_change_weight >= 0.0,
          "reward.action_change_weight must be >= 0");
  require(pos(c.reward.goal_radius), "reward.goal_radius must be > 0");
  require(std::isfinite(c.reward.goal_bonus) && std::isfinite(c.reward.collision_reward),
          "reward.goal_bonus and reward.collision_reward must be finite");
  require(std::isfinite(c.constraints.wall_margin) && c.constraints.wall_margin >= 0.0,
          "constraints.wall_margin must be >= 0");
  require(std::isfinite(c.constraints.fetch_margin) && c.constraints.fetch_margin >= 0.0,
          "constraints.fetch_margin must be >= 0");
  require(std::isfinite(c.constraints.wall_lookahead) && c.constraints.wall_lookahead >= 0.0 &&
              std::isfinite(c.constraints.fetch_lookahead) && c.constraints.fetch_lookahead >= 0.0,
          "constraints.wall_lookahead and constraints.fetch_lookahead must be >= 0");
  require(std::isfinite(c.constraints.fetch_sweep) && c.constraints.fetch_sweep >= 0.0,
          "constraints.fetch_sweep must be >= 0");
  require(std::isfinite(c.constraints.wall_buffer) && c.constraints.wall_buffer >= 0.0,
          "constraints.wall_buffer must be >= 0");
  parse_slack_type(c.constraints.slack);
  parse_basis_type(c.constraints.basis);
  require(pos(c.constraints.wall_beta) && pos(c.constraints.fetch_beta), "constraints betas must be > 0");
  require(pos(c.constraints.wall_tol) && pos(c.constraints.fetch_tol), "constraints tols must be > 0");
  require(std::isfinite(c.constraints.violation_tolerance) && c.constraints.violation_tolerance >= 0.0,
          "constraints.violation_tolerance must be >= 0");
  require(c.box2d.velocity_iterations >= 1 && c.box2d.position_iterations >= 1,
          "box2d iteration counts must be >= 1");
}

namespace {

// The one list of NavConfig's keys (src/core/config_fields.hpp), in the order
// of its JSON; the env target follows it (write_env_target / read_env_target).
template <class C, class V>
void nav_config_fields(C& c, V& v) {
  v.number("dt", c.dt, range::open_closed(0.0, 1.0));
  v.integer("horizon", c.horizon, range::closed(1, limits::kMaxHorizon));
  v.integer("block", c.block, range::closed(1, limits::kMaxEnvs));
  v.section("room", [&](auto& s) {
    s.number("x", c.room.x);
    s.number("y", c.room.y);
    s.number("wall_thickness", c.room.wall_thickness);
    s.number("spawn_fraction", c.room.spawn_fraction);
    s.number("min_start_separation", c.room.min_start_separation);
  });
  v.section("tiago", [&](auto& s) {
    s.number("radius", c.tiago.radius);
    s.number("v_max", c.tiago.v_max);
    s.number("w_max", c.tiago.w_max);
  });
  v.section("fetch", [&](auto& s) {
    s.number("radius", c.fetch.radius);
    s.object("policy", c.fetch.policy);
  });
  v.section("reward", [&](auto& s) {
    s.number("distance_weight", c.reward.distance_weight);
    s.number("heading_gain", c.reward.heading_gain);
    s.number("heading_offset", c.reward.heading_offset);
    s.number("action_change_weight", c.reward.action_change_weight);
    s.number("goal_radius", c.reward.goal_radius);
    s.number("goal_bonus", c.reward.goal_bonus);
    s.number("collision_reward", c.reward.collision_reward);
  });
  v.section("constraints", [&](auto& s) {
    s.number("wall_margin", c.constraints.wall_margin);
    s.number("fetch_margin", c.constraints.fetch_margin);
    s.number("wall_lookahead", c.constraints.wall_lookahead);
    s.number("fetch_lookahead", c.constraints.fetch_lookahead);
    s.number("fetch_sweep", c.constraints.fetch_sweep);
    s.number("wall_buffer", c.constraints.wall_buffer);
    s.string("slack", c.constraints.slack);
    s.string("basis", c.constraints.basis);
    s.number("wall_beta", c.constraints.wall_beta);
    s.number("wall_tol", c.constraints.wall_tol);
    s.number("fetch_beta", c.constraints.fetch_beta);
    s.number("fetch_tol", c.constraints.fetch_tol);
    s.number("violation_tolerance", c.constraints.violation_tolerance);
  });
  v.section("box2d", [&](auto& s) {
    s.integer("velocity_iterations", c.box2d.velocity_iterations, range::closed(1, 1000));
    s.integer("position_iterations", c.box2d.position_iterations, range::closed(1, 1000));
  });
}

}  // namespace

void to_json(nlohmann::json& j, const NavConfig& c) {
  ConfigJsonWriter w;
  nav_config_fields(c, w);
  j = std::move(w.json());
  write_env_target(j, c.target);
}

void from_json(const nlohmann::json& j, NavConfig& out) {
  NavConfig c;
  ConfigReader r(j, "env");
  ConfigFieldReader v(r);
  nav_config_fields(c, v);
  c.target = read_env_target(r);
  r.finish();
  validate(c);
  out = c;
}

nlohmann::json nav_default_config_json() {
  nlohmann::json j;
  to_json(j, default_nav_config());
  return j;
}

NavConstraintGeometry nav_constraint_geometry(const NavConfig& c) {
  NavConstraintGeometry g;
  g.room_x = c.room.x;
  g.room_y = c.room.y;
  g.tiago_radius = c.tiago.radius;
  g.fetch_radius = c.fetch.radius;
  g.wall_margin = c.constraints.wall_margin;
  g.fetch_margin = c.constraints.fetch_margin;
  g.wall_lookahead = c.constraints.wall_lookahead;
  g.fetch_lookahead = c.constraints.fetch_lookahead;
  g.fetch_sweep = c.constraints.fetch_sweep;
  g.wall_buffer = c.constraints.wall_buffer;
  return g;
}

DiffDriveSystem nav_tiago_system(const NavConfig& c) {
  DiffDriveSystem s;
  s.v_max = c.tiago.v_max;
  s.w_max = c.tiago.w_max;
  return s;
}

}  // namespace atacom
