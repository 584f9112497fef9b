// ReDSDF: a regularised learned signed distance field (paper section
// "Collision Avoidance with Learned SDFs", reference section 7).
//
// Network on x = [p (3), pose (P)], ReLU everywhere:
//   trunk   x -> hidden[0] -> ... -> hidden[trunk_layers - 1]        (features t)
//   head    t -> hidden[trunk_layers] -> ... -> hidden[last] -> f    (raw distance)
//   side    t -> side_width -> (b0, b1)
//   alpha = softplus(b0) + 1,  rho = sigmoid(b1) + 0.5,  n = |p - centre|,
//   sigma = sigmoid(alpha (n - rho)),  d = (1 - sigma) f + sigma n.
// Far from the object (n >> rho) d becomes the distance to the centre.
//
// Parameters live in one flat float buffer, each layer W (in x out) row-major
// then b (out), layers in the order trunk, head (ending in the 1-wide f
// layer), side (two layers): the layout the training tape and the batched
// kernel (kernels/redsdf_batch.hpp) both read.
//
// Weight file DIR/redsdf.bin, the one binary container
// (src/core/binary_container.hpp) with magic "ATRDSDF1" (no version field)
// and two sections: the manifest JSON (object, architecture, centre, data
// seed, metrics, training command) and the float parameters. DIR/manifest.json is a readable
// copy; the binary alone is authoritative. Both are written atomically.
#pragma once
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "src/core/aligned_vector.hpp"

namespace atacom {

struct RedsdfArch {
  int pose_dim = 0;                       // P; 0 for a static object
  std::vector<int> hidden{64, 64, 64, 64};  // trunk then head widths
  int trunk_layers = 2;                   // first layers shared by f and the side head
  int side_width = 32;                    // the side head's hidden width
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // object centre (regulariser target)

  int input_dim() const { return 3 + pose_dim; }
  // Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};
void to_json(nlohmann::json& j, const RedsdfArch& a);
void from_json(const nlohmann::json& j, RedsdfArch& a);  // unknown keys rejected, validated

struct RedsdfLayer {
  int in = 0, out = 0;
  size_t w = 0, b = 0;  // offsets of W (in x out) and b (out) in params
  bool relu = true;     // ReLU after this layer
};

// Layer table of an architecture: trunk, head (last = f, linear), side (2).
struct RedsdfLayout {
  std::vector<RedsdfLayer> trunk, head, side;
  size_t num_params = 0;
  explicit RedsdfLayout(const RedsdfArch& a);
  RedsdfLayout() = default;
  // Multiply-adds of one forward pass (all layers), per point.
  double forward_macs() const;
};

struct RedsdfModel {
  RedsdfArch arch;
  RedsdfLayout layout;
  AlignedVector<float> params;  // (layout.num_params)
  nlohmann::json manifest;      // object, data seed, metrics, command, ... (arch is added on save)

  RedsdfModel() = default;
  explicit RedsdfModel(const RedsdfArch& a);  // zero parameters
  std::string object() const { return manifest.value("object", std::string()); }
};

// Xavier-uniform weights (ReLU gain sqrt(2) on hidden layers, 1 on linear
// outputs), zero biases; deterministic in seed.
void init_redsdf(RedsdfModel& m, uint64_t seed);

// Writes DIR/redsdf.bin and DIR/manifest.json atomically (DIR is created).
void save_redsdf(const RedsdfModel& m, const std::string& dir);
// Loads DIR/redsdf.bin (or a path to the .bin itself). Throws
// std::runtime_error naming the file for a missing, truncated, corrupted
// (checksum) or inconsistent file, and for an object other than
// expected_object when that is not empty.
RedsdfModel load_redsdf(const std::string& dir_or_file, const std::string& expected_object = "");

// Slow, obvious reference in double: d and (optionally) grad_p d of one point.
// pose: (P) values, may be null when P == 0.
double redsdf_reference(const RedsdfModel& m, const Eigen::Vector3d& p, const double* pose,
                        Eigen::Vector3d* grad = nullptr);

}  // namespace atacom
