// Adam with bias correction, gradient-norm clipping and Polyak averaging over
// flat parameter buffers. Elementwise loops run on fixed blocks, the norm is
// one serial sum: results do not depend on the thread count.
#pragma once
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "train/tensor.hpp"

namespace atacom {

struct AdamConfig {
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
};
// The one default factory: PyTorch's defaults (0.9, 0.999, 1e-8).
AdamConfig default_adam_config();
void to_json(nlohmann::json& j, const AdamConfig& c);
void from_json(const nlohmann::json& j, AdamConfig& c);  // unknown keys rejected
// The same with the section's name for messages ("sac.adam").
AdamConfig read_adam_config(const nlohmann::json& j, const std::string& section);

template <class T>
class Adam {
 public:
  Adam() = default;
  Adam(size_t n, const AdamConfig& cfg) : cfg_(cfg), m_(n, T(0)), v_(n, T(0)) {}

  // One step: p -= lr * mhat / (sqrt(vhat) + eps), with
  // mhat = m / (1 - beta1^t), vhat = v / (1 - beta2^t).
  void step(T* params, const T* grads, double lr);
  // What step_fused leaves in grads: zeros, for a backward that adds into
  // them (the tape's GradMode::Add), or the gradient as the step used it
  // (subnormals flushed to 0), for one that writes them (GradMode::Set).
  enum class Grads { Zero, Keep };
  // The same step fused with what the training loop does next, chunk by
  // chunk while the arrays sit in L1: zero the gradients (ready for the next
  // backward; not with Grads::Keep) and, when target != null, Polyak-average
  // it: target = (1 - tau) target + tau params. Its bits are those of the
  // whole-block Eigen passes it was before (tests/test_adam.cpp keeps them
  // as the reference).
  void step_fused(T* params, T* grads, double lr, T* target = nullptr, double tau = 0.0,
                  Grads after = Grads::Zero);

  size_t size() const { return m_.size(); }
  const AlignedVector<T>& first_moment() const { return m_; }
  const AlignedVector<T>& second_moment() const { return v_; }
  int64_t steps() const { return t_; }
  void save(std::ostream& out) const;
  void load(std::istream& in);  // throws on size mismatch or truncation

 private:
  AdamConfig cfg_;
  AlignedVector<T> m_;  // (n) first moment, 64-byte aligned like the parameters
  AlignedVector<T> v_;  // (n) second moment
  int64_t t_ = 0;
};

// Scales grads so that their L2 norm is at most max_norm (max_norm <= 0: no
// clipping). Returns the norm before clipping; a non-finite norm leaves the
// gradient untouched and is returned so the caller can report it.
template <class T>
double clip_grad_norm(T* grads, size_t n, double max_norm);

// target = (1 - tau) target + tau source
template <class T>
void polyak_update(T* target, const T* source, size_t n, double tau);

extern template class Adam<float>;
extern template class Adam<double>;

}  // namespace atacom
