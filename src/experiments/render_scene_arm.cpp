// Render recorder of the manipulation envs: link capsules and PoI spheres
// from the arm's FK at the observed joint angles, the obstacle and the robot
// body from the env's scene, the goal and the approach axis (HRI: the human's
// capsules and the cup axis).
#include <cmath>

#include "envs/arm/arm_env.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "kernels/sdf.hpp"
#include "src/experiments/render_scene.hpp"

namespace atacom {

namespace {

using nlohmann::json;

json scene_point_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Boxes, vertical cylinders and spheres of a shape union, drawn as class cls.
void add_shapes(const ShapeUnion& u, const std::string& cls, json& statics) {
  for (const Shape& s : u.shapes) {
    const Eigen::Vector3d a(s.a[0], s.a[1], s.a[2]), h(s.half[0], s.half[1], s.half[2]);
    switch (s.type) {
      case ShapeType::Box: statics["boxes"].push_back({{"min", scene_point_json(a - h)}, {"max", scene_point_json(a + h)}, {"cls", cls}}); break;
      case ShapeType::CylinderZ:
        statics["cylinders"].push_back(
            {{"c", {a.x(), a.y()}}, {"r", s.radius}, {"z", {a.z() - h.z(), a.z() + h.z()}}, {"cls", cls}});
        break;
      case ShapeType::Sphere: statics["spheres"].push_back({{"c", scene_point_json(a)}, {"r", s.radius}, {"cls", cls}}); break;
      case ShapeType::Capsule:
        statics["capsules"].push_back(
            {{"a", scene_point_json(a)}, {"b", {s.b[0], s.b[1], s.b[2]}}, {"r", s.radius}, {"cls", cls}});
        break;
    }
  }
}

class ArmRecorder final : public RenderRecorder {
 public:
  explicit ArmRecorder(const ArmEnv& env) : env_(env) {
    const TiagoArmModel& m = env.model();
    const ArmScene& sc = env.scene();
    scene_.views = {{"top", 0, 1}, {"side", 0, 2}};
    scene_.statics = {{"boxes", json::array()}, {"cylinders", json::array()}, {"spheres", json::array()},
                      {"capsules", json::array()}, {"regions", json::array()}};
    add_shapes(sc.obstacle, "obstacle", scene_.statics);
    add_shapes(sc.body, "body", scene_.statics);
    scene_.statics["regions"].push_back({{"min", scene_point_json(sc.goal_region.min)}, {"max", scene_point_json(sc.goal_region.max)}, {"cls", "goal-region"}});
    for (const ArmCapsule& c : m.capsules) {
      scene_.capsule_radius.push_back(c.radius);
      scene_.capsule_cls.push_back("link");
    }
    for (int i = 0; i < kArmPoi; ++i) {
      scene_.sphere_radius.push_back(m.poi[static_cast<size_t>(i)].radius);
      scene_.sphere_margin.push_back(env.row_offset()[static_cast<size_t>(kRowScene + i)]);  // obstacle-row delta
      scene_.sphere_cls.push_back("poi");
    }
    scene_.axis_label = "approach axis";
    if (env.hri()) {
      for (int c = 0; c < kHumanCapsules; ++c) {
        scene_.capsule_radius.push_back(env.human_model().capsules[size_t(c)].radius);
        scene_.capsule_cls.push_back("human");
      }
      scene_.axis_label = "cup axis";
    }
  }

  const RenderScene& scene() const override { return scene_; }

  RenderFrame frame(const float* obs) const override {
    const TiagoArmModel& m = env_.model();
    ArmQ q;
    for (int j = 0; j < kArmJoints; ++j) q(j) = obs[j];
    const ArmFkResult fk = arm_fk_reference(m, q);
    RenderFrame f;
    for (const ArmCapsule& c : m.capsules) {
      const RigidTransform& T = fk.frame[static_cast<size_t>(c.frame)];
      const Eigen::Vector3d a = T.apply(c.a), b = T.apply(c.b);
      f.capsules.insert(f.capsules.end(), {a.x(), a.y(), a.z(), b.x(), b.y(), b.z()});
    }
    for (const Eigen::Vector3d& p : fk.poi) f.spheres.insert(f.spheres.end(), {p.x(), p.y(), p.z()});
    f.goal = {obs[7], obs[8], obs[9]};
    if (env_.hri()) {  // env 0's human at the state this observation belongs to
      const double* cap = env_.human_capsules_reached(0);
      f.capsules.insert(f.capsules.end(), cap, cap + kHumanCapsules * 6);
    }
    const Eigen::Vector3d ax = env_.hri() ? Eigen::Vector3d(fk.grasp.R * env_.config().hri.cup_axis) : Eigen::Vector3d(fk.grasp.R.col(0));
    f.axis = {fk.grasp.p.x(), fk.grasp.p.y(), fk.grasp.p.z(), ax.x(), ax.y(), ax.z()};
    return f;
  }

 private:
  const ArmEnv& env_;
  RenderScene scene_;
};

}  // namespace

std::unique_ptr<RenderRecorder> make_arm_render_recorder(const BatchEnv& env) {
  if (const auto* arm = dynamic_cast<const ArmEnv*>(&env)) return std::make_unique<ArmRecorder>(*arm);
  return nullptr;
}

}  // namespace atacom
