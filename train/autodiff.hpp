// Reverse-mode automatic differentiation over batched 2-D tensors.
//
// A Tape records a graph while computing it: every op evaluates its forward
// pass at once into arena memory and appends a node; backward() walks the
// nodes in reverse and each op adds (+=) its input gradients. Forward and
// backward of each op sit side by side in train/autodiff.cpp. clear() reuses
// all memory, so a training step that records the same graph every time
// allocates nothing after its first run (allocations() stays constant).
//
// Shapes are (rows x cols), row-major, rows = batch. Binary elementwise ops
// broadcast a dimension of size 1. Parameters are leaves over external
// buffers whose gradients accumulate into external grad buffers (or, with
// GradMode::Set, are written there, so nobody has to clear them); a leaf
// with a null grad pointer is a constant (frozen weights, data).
//
// Determinism: GEMMs are cut into tasks by a fixed (row block x column block)
// partition that depends only on the shapes, and every reduction runs in one
// fixed order, so results are bitwise identical for any thread count.
//
// Instantiated for float (training) and double (finite-difference checks).
#pragma once
#include <cstdint>
#include <vector>

#include "train/tensor.hpp"

namespace atacom {

enum class Op : uint8_t {
  Leaf, Linear, Add, Sub, Mul, Min, Affine, Relu, Tanh, Sigmoid, Softplus, Exp, Log, Square,
  Clamp, Sum, Mean, Concat, Slice, TanhGaussLogp,
};

template <class T>
class Tape {
 public:
  using Id = int32_t;

  // How backward() hands a parameter leaf its gradient.
  enum class GradMode : uint8_t {
    Add,  // grad += dL/dvalue
    Set,  // grad = dL/dvalue (0 where the loss does not depend on it)
  };

  struct Node {
    Op op = Op::Leaf;
    bool needs_grad = false;
    GradMode grad_mode = GradMode::Add;  // leaves with a caller's grad buffer
    bool unset = false;  // a GradMode::Set leaf whose g backward() has not written yet
    int rows = 0, cols = 0;
    T* v = nullptr;     // (rows x cols) value
    T* g = nullptr;     // (rows x cols) gradient, null when !needs_grad
    Id a = -1, b = -1, c = -1;  // inputs
    int i0 = 0, i1 = 0;         // integer attributes (groups, axis, slice bounds)
    T s0 = 0, s1 = 0;           // scalar attributes (affine, clamp bounds, eps)
    T* ext_g = nullptr;         // leaf staged in the arena: its caller's grad buffer
  };

  explicit Tape(size_t arena_chunk_elems = size_t{1} << 20);

  // Forget the graph, keep all memory.
  void clear();

  // Data that gets no gradient. The memory must outlive the graph.
  // Memory that is not 64-byte aligned is copied into the arena first (and a
  // leaf's gradient staged there and added to `grad` by backward()), so the
  // result never depends on where the caller's buffer sits.
  Id constant(const T* data, int rows, int cols);
  // External leaf; when grad != null, backward() adds dL/dvalue into grad
  // (GradMode::Add) or writes it there (GradMode::Set: grad's old contents
  // are never read, and no caller needs to clear it). Set gives the bits of
  // Add into a zeroed buffer, up to the sign of a zero gradient. (Like every
  // gradient on the tape, this holds for one backward() per recorded graph.)
  Id leaf(T* value, T* grad, int rows, int cols, GradMode mode = GradMode::Add);

  // y = x W + b for `groups` independent blocks (an ensemble in one op):
  //   W (groups*in x out), b (1 x groups*out) or -1, y (B x groups*out);
  //   x (B x groups*in), or (B x in) shared by all groups.
  // relu = true applies max(y, 0) to each output tile while it is in cache
  // (the same values and gradients as relu(linear(...)), one node fewer).
  Id linear(Id x, Id W, Id b, int groups = 1, bool relu = false);

  Id add(Id a, Id b);
  Id sub(Id a, Id b);
  Id mul(Id a, Id b);
  Id minimum(Id a, Id b);                 // ties send the gradient to a
  Id affine(Id x, T scale, T shift);      // scale * x + shift
  Id relu(Id x);
  Id tanh(Id x);
  Id sigmoid(Id x);
  Id softplus(Id x);                      // log(1 + exp(x)), overflow-safe
  Id exp(Id x);
  Id log(Id x);                           // x <= 0 gives -inf/NaN like std::log
  Id square(Id x);
  Id clamp(Id x, T lo, T hi);             // gradient passes where lo <= x <= hi
  Id sum(Id x, int axis = -1);            // -1: all -> (1 x 1); 0: over rows -> (1 x cols); 1: -> (rows x 1)
  Id mean(Id x, int axis = -1);
  Id concat(Id a, Id b);                  // along columns
  Id slice(Id x, int col_begin, int col_end);
  // Log-density of a = tanh(u), u ~ N(mu, exp(log_std)^2), per row (B x 1):
  //   sum_j [-0.5 z^2 - log_std - 0.5 log(2 pi) - log(1 - tanh(u)^2 + eps)],
  //   z = (u - mu) / exp(log_std). Gradients flow to mu, log_std and u.
  Id tanh_gauss_logp(Id mu, Id log_std, Id u, T eps = T(1e-6));

  // Backpropagate from a (1 x 1) node.
  void backward(Id loss);

  const Node& node(Id id) const { return nodes_[static_cast<size_t>(id)]; }
  Tensor<T> value(Id id) const { const Node& n = node(id); return {n.v, n.rows, n.cols}; }
  Tensor<T> grad(Id id) const { const Node& n = node(id); return {n.g, n.rows, n.cols}; }
  T scalar(Id id) const { return node(id).v[0]; }
  int size() const { return static_cast<int>(nodes_.size()); }

  // Times the tape asked the system for memory (arena chunks, node storage).
  size_t allocations() const { return arena_.growth() + node_growth_; }
  // FLOPs of all GEMMs run since construction (2 m n k each).
  double gemm_flops() const { return gemm_flops_; }

 private:
  Id push(const Node& n);
  Node make(Op op, int rows, int cols, bool needs_grad);
  Id unary(Op op, Id x);
  Id binary(Op op, Id a, Id b);
  Id reduce(Op op, Id x, int axis);
  void sweep(Id loss);  // the reverse pass of backward()
  void back_linear(const Node& n);
  void back_binary(const Node& n);
  void back_unary(const Node& n);
  void back_reduce(const Node& n);

  Arena<T> arena_;
  std::vector<Node> nodes_;
  size_t node_growth_ = 0;
  double gemm_flops_ = 0.0;
};

extern template class Tape<float>;
extern template class Tape<double>;

}  // namespace atacom
