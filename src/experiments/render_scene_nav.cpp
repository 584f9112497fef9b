// Render recorder of NavEnv: the room's walls, TIAGo and Fetch as discs
// with their headings, TIAGo's goal (all from the observation).
#include <cmath>

#include "envs/nav/nav_env.hpp"
#include "src/experiments/render_scene.hpp"

namespace atacom {

namespace {

using nlohmann::json;

class NavRecorder final : public RenderRecorder {
 public:
  explicit NavRecorder(const NavEnv& env) {
    const NavConfig& c = env.config();
    const double X = c.room.x, Y = c.room.y, w = c.room.wall_thickness, h = 0.4;
    scene_.views = {{"top", 0, 1}};
    scene_.statics = {{"boxes", json::array()}, {"cylinders", json::array()}, {"spheres", json::array()},
                      {"capsules", json::array()}, {"regions", json::array()}};
    auto wall = [&](double x0, double y0, double x1, double y1) {
      scene_.statics["boxes"].push_back({{"min", {x0, y0, 0.0}}, {"max", {x1, y1, h}}, {"cls", "wall"}});
    };
    wall(-X - w, Y, X + w, Y + w);
    wall(-X - w, -Y - w, X + w, -Y);
    wall(X, -Y, X + w, Y);
    wall(-X - w, -Y, -X, Y);
    const double s = c.room.spawn_fraction;
    scene_.statics["regions"].push_back({{"min", {-s * X, -s * Y, 0.0}}, {"max", {s * X, s * Y, 0.0}}, {"cls", "goal-region"}});
    scene_.disc_radius = {c.tiago.radius, c.fetch.radius};
    scene_.disc_cls = {"tiago", "fetch"};
  }

  const RenderScene& scene() const override { return scene_; }

  // Observation: goal x, y | TIAGo x, y, cos, sin | vx, vy, omega | Fetch x, y, cos, sin | ...
  RenderFrame frame(const float* o) const override {
    RenderFrame f;
    f.goal = {o[0], o[1], 0.0};
    f.discs = {o[2], o[3], std::atan2(o[5], o[4]), o[9], o[10], std::atan2(o[12], o[11])};
    return f;
  }

 private:
  RenderScene scene_;
};

}  // namespace

std::unique_ptr<RenderRecorder> make_nav_render_recorder(const BatchEnv& env) {
  if (const auto* nav = dynamic_cast<const NavEnv*>(&env)) return std::make_unique<NavRecorder>(*nav);
  return nullptr;
}

}  // namespace atacom
