// Learned (ReDSDF) fields for the arm envs (the obstacle, HRI's human, the
// robot body), resolved in one place:
// the env config's "sdf" map and the `--sdf analytic|learned` flag of
// `atacom rollout` / `atacom train`.
//
// A learned row keeps the analytic row's threshold plus the model's
// `safety_margin` (manifest; the largest over-estimate of the distance seen on
// its test split near the surface, rounded up), so d_learned >= delta + margin
// implies d_exact >= delta wherever that bound holds (docs/sdf.md).
#pragma once
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "envs/arm/arm_scene.hpp"
#include "kernels/redsdf_human_lanes.hpp"
#include "kernels/redsdf_lanes.hpp"

namespace atacom {

// The field of the env's obstacle per `sdf` (key: table or shelf, the env's
// own; on hri "table", the shipped field data/sdf/hri_table; null when analytic). Throws
// std::invalid_argument for a key other than the env's object or a bad value,
// std::runtime_error for a missing, corrupted or mismatched weight file.
std::shared_ptr<LearnedObstacle> load_arm_learned_obstacle(const std::map<std::string, std::string>& sdf,
                                                           const ArmSceneConfig& scene);

// HRI: the human's field per `sdf` (key "human"; null when absent or
// analytic). Same errors as above; the model must take the 34 joint angles.
std::shared_ptr<LearnedHuman> load_arm_learned_human(const std::map<std::string, std::string>& sdf);

// The robot body's field per `sdf` (key "tiago", every arm env; null when
// absent or analytic), with the env's torso lift as its pose input. Same
// errors as above; the model must take one pose input (the torso lift).
std::shared_ptr<LearnedObstacle> load_arm_learned_body(const std::map<std::string, std::string>& sdf, double torso_lift);

// Env config override for `--sdf mode` on env `env`: {"sdf": {object: mode,
// "tiago": mode}} for table and shelf, {"sdf": {"human": mode, "table": mode,
// "tiago": mode}} for hri and hri-upright; "analytic" on any other env is an
// empty override, "learned" there is an error (no shipped model).
nlohmann::json sdf_flag_override(const std::string& env, const std::string& mode);

}  // namespace atacom
