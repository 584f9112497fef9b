// Training data for the pose-conditioned learned distance field of the
// capsule human (issue 11; ReDSDF's articulated case).
//
// Frame and input: the field lives in the human's body frame (the root's
// floor position, height offset and yaw taken out: p_body = Rz(yaw)^T (p -
// (x, y, z))), and its pose input is the 34 joint angles (pose entries 4..37
// of kernels/human_kernels.hpp). The root is a rigid motion, so leaving it
// out of the network costs nothing in accuracy and keeps the input small.
//
// Poses: frames drawn uniformly from the motion library's training split
// (never its test split). Per pose: points on the 16 capsules' surfaces
// (area-weighted) shifted along the surface normal by every epsilon, plus
// uniform points of the pose's capsule bounds grown by volume_margin. Labels
// and gradients are the env's human rows' distance at the shifted point (the
// smooth minimum over the capsules with the env's blend, kernels/
// human_rows_lanes.hpp): it never exceeds the exact distance, so a bound on
// learned - label also bounds learned - exact (docs/sdf.md).
#pragma once
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "train/sdf_data.hpp"

namespace atacom {

// The HRI env's default smooth-min k over the capsules (HriConfig::human_blend).
inline constexpr double kHumanSdfDefaultBlend = 0.02;

// cfg.poses poses x cfg.surface_points surface points per pose. Deterministic in cfg.seed.
SdfSamples make_human_sdf_samples(const HumanModel& model, const HumanMotionLibrary& motion, const SdfDataConfig& cfg);

// The body-frame capsules (16 x 2 x 3, HumanBatch::cap layout) of joint angles
// q (34): the FK with the root at zero.
void human_body_capsules(const HumanModel& model, const float* q, double* cap);

// Label of point p (body frame) against body-frame capsules: the smooth min
// with blend k (k = 0: the exact min), its gradient g (optional) and the exact min.
double human_body_distance(const HumanModel& model, const double* cap, double blend, const double* p, double* g,
                           double* d_exact = nullptr);

}  // namespace atacom
