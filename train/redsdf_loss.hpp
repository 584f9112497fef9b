// The ReDSDF training loss, recorded on the autodiff tape once per batch:
//   L = mean_i w_i (d_i - y_i)^2 + gamma mean_i rho_i
//       + align * mean_{i: a_i = 1} sin^2(angle(grad_p d_i, n_i)),
// d_i = the network's distance (src/core/redsdf_model.hpp) at x_i, n_i the
// point's ground-truth normal and a_i = 1 for the points that have one.
//
// sin^2 = 1 - (n . g)^2 / (|n|^2 |g|^2) with g = grad_p d. It is what both of
// the reference's SVD projection terms come to for a scalar field (docs/sdf.md,
// "Loss"). g is put on the tape by forward-mode tangents: for each axis k the
// tangent e_k goes through the ReLU layers as T' = (T W) * mask, with the masks
// read from this batch's forward pass as constants (exact almost everywhere:
// a mask is locally constant in the weights), then through the blend's chain
// rule. Reverse mode over that graph gives the term's weight gradient. Costs
// 3 bias-free forward passes more (and their backward), about 4x the GEMMs.
//
// With align = 0 nothing beyond the first two terms is recorded: the graph,
// and so every bit of the training, is what it was before the term existed.
//
// All scratch is allocated in the constructor; record() allocates nothing.
// Instantiated for float (training) and double (finite-difference checks).
#pragma once
#include <vector>

#include "src/core/redsdf_model.hpp"
#include "train/autodiff.hpp"
#include "train/tensor.hpp"

namespace atacom {

template <class T>
struct RedsdfLossBatch {
  int B = 0;
  const T* x = nullptr;       // (B x input_dim) [p, pose]
  const T* radius = nullptr;  // (B) |p - centre|
  const T* y = nullptr;       // (B) labels
  const T* w = nullptr;       // (B) WMSE weights
  const T* normal = nullptr;  // (B x 3) ground-truth normals; read only when align > 0
  const T* has_normal = nullptr;  // (B) 1 where the normal counts, 0 elsewhere; read only when align > 0
};

template <class T>
class RedsdfLoss {
 public:
  using Id = typename Tape<T>::Id;
  struct Terms {
    Id loss = -1, wmse = -1, rho_mean = -1;
    Id align = -1;       // mean sin^2 over the points with a normal; -1 when not recorded
    int normals = 0;     // points of the batch that count in it
  };

  // Scratch for batches of up to max_batch points of this architecture.
  RedsdfLoss(const RedsdfArch& arch, int max_batch);

  // params / grads: the flat buffers of RedsdfLayout(arch); grads are added to
  // by tape.backward(terms.loss). align > 0 records the alignment term (when
  // the batch has no point with a normal it is left out).
  Terms record(Tape<T>& tp, T* params, T* grads, const RedsdfLossBatch<T>& b, T gamma, T align);

 private:
  RedsdfArch arch_;
  RedsdfLayout layout_;
  int max_batch_;
  std::vector<AlignedVector<T>> mask_;  // per ReLU layer (trunk, head, side order): (B x out) 0/1
  AlignedVector<T> unit_[3], nrm_[3];   // (B) columns of (p - centre) / |p - centre| and of n / |n|
  AlignedVector<T> has_;                // (B) 0/1 where the normal counts
  AlignedVector<T> onehot_[3];          // (1 x input_dim) e_k
  std::vector<Id> wid_, out_;           // per layer of this record(): weight leaf, output node
};

extern template class RedsdfLoss<float>;
extern template class RedsdfLoss<double>;

}  // namespace atacom
