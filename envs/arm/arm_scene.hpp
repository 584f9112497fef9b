// Scenes of the manipulation envs: the obstacle (table or shelf), the robot
// body and the task regions, all in base_footprint (x forward, z up).
//
// Object geometry comes from data/tiago_arm.json (scene_reference: the
// authors' table model and the box bounds of their shelf parts). Where it
// stands is ours (the paper's placement is not public): the object frame is
// placed at `position` and turned about z by `yaw_deg`, a multiple of 90
// degrees so every box stays axis-aligned and its distance exact.
// Regions (goal sampling box, reward indicator box) are given in the object
// frame and move with it.
#pragma once
#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "kernels/sdf.hpp"
#include "envs/arm/tiago_model.hpp"

namespace atacom {

enum class ArmTask : uint8_t { Table = 0, Shelf = 1, Hri = 2 };
std::string arm_task_name(ArmTask t);
ArmTask parse_arm_task(const std::string& s);  // throws std::invalid_argument

struct AlignedBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  bool contains(const Eigen::Vector3d& p) const {
    return (p.array() >= min.array()).all() && (p.array() <= max.array()).all();
  }
  Eigen::Vector3d center() const { return 0.5 * (min + max); }
};

struct ArmSceneConfig {
  ArmTask task = ArmTask::Table;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // object frame origin in base_footprint
  int yaw_deg = 0;                                      // 0, 90, 180 or 270
  double blend = 0.0;                                   // smooth-union k of the obstacle, m
  double body_blend = 0.0;                              // smooth-union k of the robot body, m
  AlignedBox goal_region;                               // object frame
  AlignedBox indicator_region;                          // object frame
};

// The one default factory per task (placement documented in docs/envs_arm.md).
ArmSceneConfig default_arm_scene_config(ArmTask task);
void to_json(nlohmann::json& j, const ArmSceneConfig& c);
void from_json(const nlohmann::json& j, ArmSceneConfig& c);  // unknown keys rejected

struct ArmScene {
  ShapeUnion obstacle;            // table or shelf boxes (HRI: the shared table)
  ShapeUnion body;                // base cylinder, torso box, head sphere
  AlignedBox obstacle_bounds;     // box around every obstacle shape (broad phase)
  AlignedBox goal_region;         // base_footprint
  AlignedBox indicator_region;    // base_footprint
};

ArmScene build_arm_scene(const ArmSceneConfig& config, const TiagoArmModel& model);

// Where the object frame sits: base_footprint point = R * object point + t.
void arm_object_placement(const ArmSceneConfig& config, Eigen::Matrix3d& R, Eigen::Vector3d& t);

}  // namespace atacom
