// Training a ReDSDF network from exact geometry (`atacom sdf-train`).
//
// Loss (reference section 7.3; train/redsdf_loss.hpp records it):
//   L = mean_i w_i (d(x_i) - y_i)^2 + gamma mean_i rho(x_i)
//       + align_weight mean_{i shifted} sin^2(angle(grad_p d(x_i), n_i)),
// w_i = near_weight where |y_i| < 0.1 m, else 1; the last term (the
// reference's two SVD projection terms, which for a scalar field both come to
// sin^2) runs over the batch's shifted surface samples with n_i = the exact
// label gradient, and is not recorded at all when align_weight = 0. Adam with a learning rate
// decaying linearly from lr to lr_final over max_epochs; a 0.8/0.1/0.1
// train/validation/test split; early stopping on the validation WMSE with
// `patience` epochs (the best weights are kept), and a wall-clock budget.
// Deterministic in the seeds for any thread count (the tape's GEMM partition
// and the batched kernel's blocks are fixed).
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/redsdf_model.hpp"
#include "train/sdf_data.hpp"

namespace atacom {

struct SdfTrainConfig {
  std::string object = "table";  // table | shelf | human | tiago
  RedsdfArch arch;
  SdfDataConfig data;
  int batch = 1024;
  double lr = 1e-3, lr_final = 1e-4;
  int max_epochs = 200;
  int patience = 25;
  double gamma = 0.02;        // rho regulariser
  double near_weight = 4.0;   // loss weight of points within 0.1 m of the surface
  double align_weight = 0.0;  // gradient-alignment term (0: today's loss, bit for bit)
  double budget_s = 240.0;    // wall-clock limit of the epoch loop
  uint64_t init_seed = 1;     // weights and batch order
};
// The one default factory per object (sizes in docs/sdf.md).
SdfTrainConfig default_sdf_train_config(const std::string& object);
void to_json(nlohmann::json& j, const SdfTrainConfig& c);
void from_json(const nlohmann::json& j, SdfTrainConfig& c);  // unknown keys rejected

// The object's geometry in its own frame (the arm scene's object at
// position 0, yaw 0, with the scene's smooth-union blend), and the centre the regulariser pulls towards (the
// middle of its bounds). Throws std::invalid_argument for an unknown object.
ShapeUnion sdf_object_geometry(const std::string& object, Eigen::Vector3d* centre = nullptr);

// Accuracy of a model against exact labels (see docs/sdf.md for the terms).
nlohmann::json sdf_accuracy(const RedsdfModel& m, const SdfSamples& s, const std::vector<int>& idx);

// Trains, writing DIR/progress.csv, DIR/learning_curve.svg, DIR/config.json
// and the weights (DIR/redsdf.bin, DIR/manifest.json) atomically; prints one
// progress line per epoch when `progress`. Returns the manifest.
nlohmann::json train_sdf(const SdfTrainConfig& cfg, const std::string& dir, const std::string& command, bool progress);

}  // namespace atacom
