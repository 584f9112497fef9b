// Multi-layer perceptron on the autodiff tape, optionally an ensemble.
//
// An ensemble of E members with identical topology runs as one set of grouped
// linear ops (the twin critics are one Mlp with E = 2), so each layer is one
// tape node and one partitioned GEMM pass. All weights and biases of all
// members live in one flat buffer, which makes Adam, Polyak averaging and
// checkpoints single loops over contiguous memory.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "train/autodiff.hpp"
#include "atacom/rng.hpp"

namespace atacom {

enum class Activation : uint8_t { Relu = 0, Tanh = 1, Sigmoid = 2, Softplus = 3 };
std::string activation_name(Activation a);
Activation parse_activation(const std::string& s);  // throws std::invalid_argument
// Xavier-uniform gain recommended for the activation (sqrt(2) for ReLU).
double activation_gain(Activation a);

struct MlpConfig {
  std::vector<int> hidden = {256, 256};  // hidden layer widths
  Activation activation = Activation::Relu;  // hidden layers; the output is linear
};
// The one default factory (MlpConfig{}): 256-256 ReLU (the paper's networks).
MlpConfig default_mlp_config();
void to_json(nlohmann::json& j, const MlpConfig& c);
void from_json(const nlohmann::json& j, MlpConfig& c);  // unknown keys rejected
// The same with the section's name for messages ("sac.actor"): widths in
// [1, limits::kMaxMlpWidth], 1 to limits::kMaxMlpLayers layers.
MlpConfig read_mlp_config(const nlohmann::json& j, const std::string& section);

template <class T>
class Mlp {
 public:
  Mlp() = default;
  // in -> hidden... -> out, `ensemble` members.
  Mlp(int in, int out, const MlpConfig& cfg, int ensemble = 1);

  // Xavier-uniform weights with the activation's gain on every layer
  // (output included, as the paper's code does); zero biases.
  void init(Rng& rng);

  // x: (B x in), shared by all members, or (B x ensemble*in).
  // Returns (B x ensemble*out). param_grads = false freezes the weights
  // (gradients still flow to x); otherwise backward() adds the parameter
  // gradients into grads() or, with GradMode::Set, writes them there.
  typename Tape<T>::Id forward(Tape<T>& tape, typename Tape<T>::Id x, bool param_grads,
                               typename Tape<T>::GradMode mode = Tape<T>::GradMode::Add);

  AlignedVector<T>& params() { return params_; }
  const AlignedVector<T>& params() const { return params_; }
  AlignedVector<T>& grads() { return grads_; }
  const AlignedVector<T>& grads() const { return grads_; }
  void zero_grad();

  int in() const { return in_; }
  int out() const { return out_; }
  int ensemble() const { return ensemble_; }
  int num_layers() const { return static_cast<int>(layers_.size()); }
  // FLOPs of one forward pass per sample (2 * multiply-adds of all layers).
  double forward_flops_per_sample() const;

 private:
  struct Layer { int in, out; size_t w, b; };  // offsets into params_: W (E*in x out), b (1 x E*out)
  int in_ = 0, out_ = 0, ensemble_ = 1;
  Activation act_ = Activation::Relu;
  std::vector<Layer> layers_;
  AlignedVector<T> params_;  // (num_params) all members, all layers
  AlignedVector<T> grads_;   // (num_params) accumulated by Tape::backward
};

extern template class Mlp<float>;
extern template class Mlp<double>;

}  // namespace atacom
