// The Box2D side of the navigation env: one single-threaded b2World per env
// (zero gravity, top down); the four walls are static boxes, TIAGo and Fetch
// dynamic discs whose velocities the step kernel sets so that Box2D's
// position update lands on the unicycle's closed-form step
// (docs/envs_nav.md). Only this file's .cpp includes Box2D. Worlds of
// different envs are independent: ranges of envs step concurrently.
#pragma once
#include <cstdint>
#include <memory>
#include <vector>

#include "envs/nav/nav_config.hpp"

namespace atacom {

class NavWorlds {
 public:
  // Builds n worlds for config c (and warms Box2D's static tables once per process).
  NavWorlds(const NavConfig& c, int n);
  ~NavWorlds();
  NavWorlds(const NavWorlds&) = delete;
  NavWorlds& operator=(const NavWorlds&) = delete;

  // A fresh world for env e (snapshot loading).
  void rebuild(int e);
  // Sets both bodies' poses [x, y, theta] (rounded to float) and stops TIAGo.
  void place(int e, const double* tiago_pose, const double* fetch_pose);
  // World vx, vy, omega of each body for the next step (rounded to float).
  void set_tiago_velocity(int e, const double* vel);
  void set_fetch_velocity(int e, const double* vel);
  // Integrates one control period, then reads TIAGo's contacts at the reached
  // poses (a wall, Fetch).
  void step(int e, uint8_t* hit_wall, uint8_t* hit_fetch);
  // The reached poses and the velocity TIAGo moved with, widened to double.
  void read(int e, double* tiago_pose, double* fetch_pose, double* tiago_vel) const;

 private:
  struct World;
  NavConfig cfg_;
  std::vector<std::unique_ptr<World>> worlds_;  // (N)
};

}  // namespace atacom
