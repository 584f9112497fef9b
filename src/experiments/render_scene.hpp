// What `atacom render` draws, per env family: a static scene (boxes,
// cylinders, spheres, regions, walls) and, per step, the moving geometry
// (capsules, spheres with their constraint margins, discs with a heading,
// the goal, an axis arrow), all in the env's world frame (m). Recorders read
// the envs' own models through their read-only accessors and the state the
// step reached through its observation (EnvBuffers::final_obs), which an
// autoreset does not overwrite.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"

namespace atacom {

// Moving geometry of one step.
struct RenderFrame {
  std::vector<double> capsules;  // (C x 6) end points a, b
  std::vector<double> spheres;   // (S x 3) centres
  std::vector<double> discs;     // (D x 3) x, y, heading (rad)
  std::vector<double> goal;      // (3) or empty
  std::vector<double> axis;      // (6) origin and unit direction (cup / approach axis) or empty
};

struct RenderScene {
  // Views: name and the two world axes they show (0 = x, 1 = y, 2 = z).
  struct View {
    std::string name;
    int u = 0, v = 1;
  };
  std::vector<View> views;
  // Static geometry, world frame: JSON arrays of
  //   boxes      {"min": [3], "max": [3], "cls": s}
  //   cylinders  {"c": [x, y], "r": r, "z": [z0, z1], "cls": s}   (vertical)
  //   spheres    {"c": [3], "r": r, "cls": s}
  //   regions    {"min": [3], "max": [3], "cls": s}              (outlined boxes)
  nlohmann::json statics = nlohmann::json::object();
  // Per moving element (fixed over the episode): radius and class; spheres
  // also their constraint margin radius (0: none drawn).
  std::vector<double> capsule_radius, sphere_radius, sphere_margin, disc_radius;
  std::vector<std::string> capsule_cls, sphere_cls, disc_cls;
  std::string axis_label;  // e.g. "approach axis", "cup axis"
};

class RenderRecorder {
 public:
  virtual ~RenderRecorder() = default;
  virtual const RenderScene& scene() const = 0;
  // The moving geometry of env 0 at the state whose observation is obs.
  virtual RenderFrame frame(const float* obs) const = 0;
};

// The recorder of an env (the plain env, below any safety layer). Throws
// std::invalid_argument for envs that cannot be drawn.
std::unique_ptr<RenderRecorder> make_render_recorder(const BatchEnv& env);

// Family recorders (render_scene_arm.cpp, render_scene_nav.cpp); nullptr
// when env is not of the family.
std::unique_ptr<RenderRecorder> make_arm_render_recorder(const BatchEnv& env);
std::unique_ptr<RenderRecorder> make_nav_render_recorder(const BatchEnv& env);

}  // namespace atacom
