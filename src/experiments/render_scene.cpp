#include "src/experiments/render_scene.hpp"

#include <stdexcept>

#include "atacom/safe_env.hpp"

namespace atacom {

std::unique_ptr<RenderRecorder> make_render_recorder(const BatchEnv& env) {
  if (auto r = make_arm_render_recorder(env)) return r;
  if (auto r = make_nav_render_recorder(env)) return r;
  throw std::invalid_argument("env '" + env.spec().name + "' has no picture (atacom render draws table, shelf, nav, hri)");
}

}  // namespace atacom
