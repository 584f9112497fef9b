// Training data for a learned distance field of a static object, from its
// exact geometry (a union of boxes): surface samples with their face normals,
// offset along the normal by each of a list of signed distances (the
// reference's epsilon list), plus uniform samples of a box around the object
// for the far field. Labels and gradients are the exact union distance at the
// shifted point, not the offset (so an offset that crosses a thin part or
// lands near another part is still labelled right, and nothing needs the
// reference's cleaning step). By default the union is the env's smooth union
// (kernels/sdf.hpp): it never exceeds the exact distance, so a bound on
// learned - label is also a bound on learned - exact, and the field has no
// kinks at the seams between parts (which made ATACOM overshoot there).
#pragma once
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

#include "kernels/sdf.hpp"

namespace atacom {

struct SdfDataConfig {
  int surface_points = 8000;                   // surface samples, each shifted by every epsilon
  std::vector<double> epsilons;                // signed offsets along the normal, m
  double volume_fraction = 0.2;                // extra uniform samples, as a fraction of the surface ones
  double volume_margin = 0.8;                  // the uniform box: object bounds grown by this, m
  int poses = 1;                               // human: poses of the motion library's training split; tiago: torso lifts
  double blend = -1.0;                         // labels' smooth-union k, m: -1 = the object's own
                                               // (the env's rows), 0 = the exact min
  uint64_t seed = 1;
};
// The one default factory: the reference's TIAGo epsilon list (20 values).
SdfDataConfig default_sdf_data_config();
void to_json(nlohmann::json& j, const SdfDataConfig& c);
void from_json(const nlohmann::json& j, SdfDataConfig& c);  // unknown keys rejected, ranges checked

struct SdfSamples {
  int n = 0;
  int pose_dim = 0;           // P (0: a static object)
  std::vector<float> poses;   // (num poses x P) the network's pose inputs
  std::vector<int> pose_id;   // (n) each point's row of `poses` (empty when P == 0)
  std::vector<float> p;     // (n x 3) points, object frame
  std::vector<float> y;     // (n) exact signed distance
  std::vector<float> grad;  // (n x 3) exact gradient (nearest primitive's, unit)
  // (n) 1: a surface sample shifted along its normal (the points the loss's
  // alignment term uses, with `grad` as their normal), 0: a uniform volume sample.
  std::vector<uint8_t> shifted;
};

// Samples for `object` (boxes only; other primitives are rejected with a
// message naming the shape). Deterministic in cfg.seed.
SdfSamples make_static_sdf_samples(const ShapeUnion& object, const SdfDataConfig& cfg);

// Axis-aligned bounds of a union of boxes.
void union_box_bounds(const ShapeUnion& object, Eigen::Vector3d& lo, Eigen::Vector3d& hi);

}  // namespace atacom
