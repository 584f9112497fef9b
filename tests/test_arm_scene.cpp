// Scene geometry and placement of the manipulation envs.
#include <catch2/catch.hpp>

#include "envs/arm/arm_scene.hpp"

using namespace atacom;

TEST_CASE("table scene: the authors' table, long side facing the robot", "[arm_scene]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  const ArmScene s = build_arm_scene(default_arm_scene_config(ArmTask::Table), m);
  REQUIRE(s.obstacle.shapes.size() == 5);  // top + 4 legs
  const Shape& top = s.obstacle.shapes[0];
  CHECK(top.a[2] + top.half[2] == Approx(0.625));         // top surface height
  CHECK(top.a[0] - top.half[0] == Approx(0.45));          // near edge in front of the robot
  CHECK(2 * top.half[1] == Approx(1.5));                  // long side along y
  CHECK(s.obstacle_bounds.min.z() == Approx(0.0));        // legs stand on the floor
  // The goal region is above the table top and inside its footprint.
  CHECK(s.goal_region.min.z() > 0.625);
  CHECK(s.goal_region.min.x() >= top.a[0] - top.half[0]);
  // Robot body: base cylinder on the floor, torso on the base, head above.
  REQUIRE(s.body.shapes.size() == 3);
  CHECK(shape_distance(s.body.shapes[0], {0.0, 0.0, 0.1}) < 0.0);
  CHECK(shape_distance(s.body.shapes[1], {-0.06, 0.0, 0.8}) < 0.0);
  CHECK(shape_distance(s.body.shapes[2], m.body.head_center) == Approx(-m.body.head_radius));
}

TEST_CASE("shelf scene: open side towards the robot, standing on the floor", "[arm_scene]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  const ArmScene s = build_arm_scene(default_arm_scene_config(ArmTask::Shelf), m);
  REQUIRE(s.obstacle.shapes.size() == 7);
  CHECK(s.obstacle_bounds.min.x() == Approx(0.55));  // front face
  CHECK(s.obstacle_bounds.min.z() == Approx(0.0));
  CHECK(s.obstacle_bounds.max.z() == Approx(1.0));
  // The back plank is the farthest part from the robot.
  for (const Shape& sh : s.obstacle.shapes)
    if (sh.name == "shelf_back_plank") CHECK(sh.a[0] + sh.half[0] == Approx(s.obstacle_bounds.max.x()));
  // Goals: inside the shelf's footprint, above the middle plank, clear of every part.
  const Eigen::Vector3d g = s.goal_region.center();
  CHECK(union_distance_exact(s.obstacle, g) > 0.1);
  CHECK(s.indicator_region.contains(g));
}

TEST_CASE("scene config: JSON round trip, yaw and region checks", "[arm_scene]") {
  ArmSceneConfig c = default_arm_scene_config(ArmTask::Shelf);
  nlohmann::json j = c;
  ArmSceneConfig back;
  from_json(j, back);
  CHECK(nlohmann::json(back) == j);
  j["yaw_deg"] = 30;
  CHECK_THROWS_WITH(from_json(j, back), Catch::Contains("multiple of 90"));
  j = c;
  j["goal_region"]["min"] = {1.0, 1.0, 1.0};
  CHECK_THROWS_WITH(from_json(j, back), Catch::Contains("goal_region"));
  j = c;
  j["extra"] = 1;
  CHECK_THROWS_WITH(from_json(j, back), Catch::Contains("extra"));
  // A turned placement moves regions with the object.
  c.yaw_deg = 0;
  const ArmScene s = build_arm_scene(c, load_tiago_arm_model(0.1));
  CHECK(s.goal_region.min.x() == Approx(c.position.x() + c.goal_region.min.x()));
}
