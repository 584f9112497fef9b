// Accuracy of a learned distance field along the arm's points of interest
// during rollouts (issue 11, part 3: "on the exact geometry near the PoIs'
// actual paths"): random-alpha rollouts of an arm env with its learned field,
// through ATACOM or raw (safety "none": paths that also reach the surface);
// after every step, each PoI of every env that did not just end is
// evaluated with the learned field and with the analytic one (the env's
// smooth-union rows) and the exact distance. The field is the env's object
// or the robot body (its learned field conditioned on the env's torso lift).
// Figures: docs/sdf.md.
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom {

struct SdfPathConfig {
  std::string env = "table";  // table | shelf | hri
  std::string field = "obstacle";  // obstacle (the env's object: table, shelf or hri's human) | body (the TIAGo body)
  long steps = 20000;         // env steps over all envs
  int envs = 64;
  uint64_t seed = 1;
  std::string split = "train";  // hri: the motion split the humans replay (train | test)
  std::string safety = "atacom";  // atacom (the paths the learned rows allow) | none (raw random actions: paths
                                  // that also cross the surface)
};

// {"env", "object", "steps", "points", "margin", "near" / "mid" / "far" /
// "all": {points, mean_abs_err, max_abs_err, grad_angle_mean_deg,
// grad_angle_p95_deg}, "max_overestimate_band" (learned - analytic with
// analytic in [-0.15, 0.3] m), "max_over_exact" (learned - exact, same band),
// "min_analytic", "inside_points", "clear_while_inside" (learned > margin
// while analytic < 0)}. near: |analytic| < 0.1 m, mid: 0.1-0.3, far: > 0.3.
nlohmann::json sdf_path_accuracy(const SdfPathConfig& c);

}  // namespace atacom
