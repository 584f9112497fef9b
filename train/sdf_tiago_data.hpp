// Training data for the learned distance field of the TIAGo body (issue 11;
// the robot-body rows of envs/arm/arm_rows.hpp).
//
// Geometry and input: the body the rows use (base cylinder, torso box, head
// sphere; envs/arm/arm_scene.cpp) is static in base_footprint for a fixed
// torso. The arm is not part of it (the body rows are arm PoIs against the
// body), so the field takes no arm joints. Its one pose input is the torso
// lift, m: the envs fix the torso at different heights (table and shelf 0.1,
// hri 0.3) and the torso box's top and the head move with it, so one model
// serves every env. The field lives in base_footprint (no placement).
//
// Poses: lifts drawn uniformly from [0, 0.35] m (the joint's range). Per lift:
// points on the three primitives' surfaces (area-weighted, rejected when
// buried in another part) shifted along the normal by every epsilon (the
// reference's TIAGo list), plus uniform points of the body's bounds grown by
// volume_margin. Labels and gradients are the env's body-row distance at the
// shifted point (the smooth union with the scene's body_blend): it never
// exceeds the exact distance, so a bound on learned - label also bounds
// learned - exact (docs/sdf.md).
#pragma once
#include "atacom/rng.hpp"
#include "train/sdf_data.hpp"

namespace atacom {

inline constexpr double kTiagoSdfLiftMax = 0.35;  // torso_lift_joint upper limit, m

// The body the env's rows use at torso lift `lift` (blend: the scene's body_blend).
ShapeUnion tiago_body_geometry(double lift);

// The regulariser's centre: the middle of the body's bounds at mid lift.
Eigen::Vector3d tiago_body_centre();

// cfg.poses lifts x cfg.surface_points surface points per lift. Deterministic in cfg.seed.
SdfSamples make_tiago_sdf_samples(const SdfDataConfig& cfg);

// Area-weighted uniform point on the surface of a box, vertical cylinder or
// sphere, with its outward unit normal (exposed for the tests).
double shape_surface_area(const Shape& s);
void sample_shape_surface(const Shape& s, Rng& rng, Eigen::Vector3d& point, Eigen::Vector3d& normal);

}  // namespace atacom
