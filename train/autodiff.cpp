#include "train/autodiff.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <Eigen/Core>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "atacom/parallel.hpp"
#include "kernels/eigen_exact_gemm.hpp"

namespace atacom {

namespace {

// GEMM partition: output tiles of at most kRowBlock x kColBlock. Fixed, so the
// same shapes always give the same tiles (and the same rounding) whatever the
// thread count. Below kParallelFlops a GEMM runs its tiles on the calling
// thread: a TBB round trip costs more than the work.
constexpr int kRowBlock = 256;
constexpr int kColBlock = 128;
constexpr double kParallelFlops = 1.5e6;
// Elementwise loops go parallel above this many elements (any partition of an
// elementwise loop gives the same bits).
constexpr int64_t kParallelElems = 1 << 16;

int blocks(int n, int b) { return (n + b - 1) / b; }

template <class Fn>
void run_tasks(int ntasks, double flops, Fn&& fn) {
  if (ntasks <= 1 || flops < kParallelFlops) {
    for (int t = 0; t < ntasks; ++t) fn(t);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, ntasks, 1),
                    [&](const tbb::blocked_range<int>& r) {
                      for (int t = r.begin(); t != r.end(); ++t) fn(t);
                    },
                    tbb::simple_partitioner());
}

template <class Fn>
void for_elems(int64_t n, Fn&& fn) {
  if (n < kParallelElems) { fn(int64_t{0}, n); return; }
  parallel_blocks(n, kParallelElems / 2, fn);
}

// The message is built only on failure: a check that passes allocates nothing.
template <class Msg>
void check(bool ok, const char* op, Msg&& what) {
  if (!ok) throw std::invalid_argument(std::string("autodiff ") + op + ": " + std::string(what()));
}

// float tiles go to the Eigen-exact kernel where it takes them (the same
// bits as the Eigen expression each call site falls back to, without the
// packing); double tiles, used by the finite-difference checks, stay Eigen's.
template <class T>
bool exact_tile(int m, int n, int k, const T* a, int64_t a_rs, int64_t a_cs, const T* b, int64_t b_rs, int64_t b_cs,
                T* c, int64_t ldc, const T* c_init, bool relu) {
  if constexpr (std::is_same_v<T, float>)
    return eigen_exact_gemm(m, n, k, a, a_rs, a_cs, b, b_rs, b_cs, c, ldc, c_init, relu);
  else return false;
}

std::string shape(int r, int c) {
  std::string s(1, '(');  // built piecewise: GCC 12 warns falsely (-Wrestrict) on "(" + std::string
  s += std::to_string(r);
  s += " x ";
  s += std::to_string(c);
  s += ')';
  return s;
}

}  // namespace

template <class T>
Tape<T>::Tape(size_t arena_chunk_elems) : arena_(arena_chunk_elems) {
  nodes_.reserve(256);
  node_growth_ = 1;
}

template <class T>
void Tape<T>::clear() {
  nodes_.clear();
  arena_.reset();
}

template <class T>
typename Tape<T>::Id Tape<T>::push(const Node& n) {
  if (nodes_.size() == nodes_.capacity()) ++node_growth_;
  nodes_.push_back(n);
  return static_cast<Id>(nodes_.size() - 1);
}

// A new node with value storage and, when needed, zeroed gradient storage.
template <class T>
typename Tape<T>::Node Tape<T>::make(Op op, int rows, int cols, bool needs_grad) {
  Node n;
  n.op = op;
  n.rows = rows;
  n.cols = cols;
  n.needs_grad = needs_grad;
  const size_t sz = size_t(rows) * size_t(cols);
  n.v = arena_.alloc(sz);
  if (needs_grad) {
    n.g = arena_.alloc(sz);
    std::memset(n.g, 0, sz * sizeof(T));
  }
  return n;
}

// ---------------------------------------------------------------- leaves

template <class T>
typename Tape<T>::Id Tape<T>::constant(const T* data, int rows, int cols) {
  return leaf(const_cast<T*>(data), nullptr, rows, cols);  // never written: no grad
}

template <class T>
typename Tape<T>::Id Tape<T>::leaf(T* value, T* grad, int rows, int cols, GradMode mode) {
  Node n;
  n.op = Op::Leaf;
  n.rows = rows;
  n.cols = cols;
  n.needs_grad = grad != nullptr;
  n.grad_mode = mode;
  const size_t sz = size_t(rows) * size_t(cols);
  if (is_aligned64(value)) {
    n.v = value;
  } else {
    n.v = arena_.alloc(sz);
    std::memcpy(n.v, value, sz * sizeof(T));
  }
  if (grad && is_aligned64(grad)) {
    n.g = grad;
    n.unset = mode == GradMode::Set;  // the caller's buffer, uncleared
  } else if (grad) {  // staged: zeroed here, handed over (+= or =) at the end of backward()
    n.g = arena_.alloc(sz);
    std::memset(n.g, 0, sz * sizeof(T));
    n.ext_g = grad;
  }
  return push(n);
}

// ---------------------------------------------------------------- linear
// Forward: y_q = x_q W_q + b_q per group q, tiled (row block x column block).
namespace {
// Restrict-qualified pointers by value, so the loops vectorise.
template <class T>
void relu_rows(T* __restrict y, int64_t ld, int rows, int cols) {
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) y[i * ld + j] = y[i * ld + j] > T(0) ? y[i * ld + j] : T(0);
}
template <class T>
void relu_mask_grad(T* __restrict g, const T* __restrict v, int64_t lo, int64_t hi) {
  for (int64_t k = lo; k < hi; ++k) g[k] = v[k] > T(0) ? T(0) + g[k] : T(0);
}
// Rows a tile starts from: the kernel reads C's initial row in place.
template <class T>
constexpr T kZeroRow[kColBlock] = {};
}  // namespace

template <class T>
typename Tape<T>::Id Tape<T>::linear(Id xi, Id wi, Id bi, int groups, bool relu) {
  const Node& x = node(xi);
  const Node& w = node(wi);
  check(groups >= 1 && w.rows % groups == 0, "linear", [&] {
    return "weight rows " + std::to_string(w.rows) + " not divisible by groups " + std::to_string(groups);
  });
  const int in = w.rows / groups, out = w.cols, B = x.rows;
  const bool shared = groups > 1 && x.cols == in;
  check(x.cols == in * groups || shared, "linear",
        [&] { return "input " + shape(x.rows, x.cols) + " does not match weight " + shape(w.rows, w.cols); });
  if (bi >= 0) {
    const Node& b = node(bi);
    check(b.rows == 1 && b.cols == out * groups, "linear",
          [&] { return "bias " + shape(b.rows, b.cols) + " expected " + shape(1, out * groups); });
  }
  const bool ng = x.needs_grad || w.needs_grad || (bi >= 0 && node(bi).needs_grad);
  Node y = make(Op::Linear, B, out * groups, ng);
  y.a = xi; y.b = wi; y.c = bi; y.i0 = groups; y.i1 = relu ? 1 : 0;
  const T* xv = x.v;
  const T* wv = w.v;
  const T* bv = bi >= 0 ? node(bi).v : nullptr;
  T* yv = y.v;
  const int ldx = x.cols, ldy = out * groups;
  const int rb = blocks(B, kRowBlock), cb = blocks(out, kColBlock);
  const double flops = 2.0 * B * in * out * groups;
  gemm_flops_ += flops;
  run_tasks(groups * rb * cb, flops, [&](int t) {
    const int q = t / (rb * cb), r = (t / cb) % rb, c = t % cb;
    const int r0 = r * kRowBlock, nr = std::min(kRowBlock, B - r0);
    const int c0 = c * kColBlock, nc = std::min(kColBlock, out - c0);
    T* yt = yv + int64_t(r0) * ldy + q * out + c0;
    const T* xt = xv + int64_t(r0) * ldx + (shared ? 0 : q * in);
    const T* wt = wv + int64_t(q) * in * out + c0;
    // Every row starts as the bias (or zeros); the kernel reads it in place,
    // the Eigen fallback gets it copied in first: the same bits either way.
    const T* init = bv ? bv + q * out + c0 : kZeroRow<T>;
    if (exact_tile<T>(nr, nc, in, xt, ldx, 1, wt, out, 1, yt, ldy, init, relu)) return;
    for (int i = 0; i < nr; ++i) std::memcpy(yt + int64_t(i) * ldy, init, sizeof(T) * size_t(nc));
    MatMap<T> Y(yt, nr, nc, Eigen::OuterStride<>(ldy));
    CMatMap<T> X(xt, nr, in, Eigen::OuterStride<>(ldx));
    CMatMap<T> W(wt, in, nc, Eigen::OuterStride<>(out));
    Y.noalias() += X * W;
    if (relu) relu_rows<T>(yt, ldy, nr, nc);
  });
  return push(y);
}

// Backward: dx_q += dy_q W_q^T (tiles over x's columns; a shared input sums
// its groups in order inside one tile), dW_q += x_q^T dy_q and db_q += sum_rows
// dy_q (tiles over W's columns, all rows in one fixed pass).
template <class T>
void Tape<T>::back_linear(const Node& y) {
  const Node& x = node(y.a);
  const Node& w = node(y.b);
  const Node* b = y.c >= 0 ? &node(y.c) : nullptr;
  const int groups = y.i0, in = w.rows / groups, out = w.cols, B = x.rows;
  const bool shared = groups > 1 && x.cols == in;
  const int ldx = x.cols, ldy = y.cols;
  const bool dx = x.needs_grad, dw = w.needs_grad, db = b && b->needs_grad;
  // A GradMode::Set parameter's first contribution is written, not added:
  // C = 0 + X^T dY from a zero row (the bits of += into a zeroed buffer),
  // without reading the buffer's stale contents.
  const bool set_w = dw && w.unset, set_b = db && b->unset;
  const int rb = blocks(B, kRowBlock);
  const int xcb = blocks(in, kColBlock);
  const int xgroups = shared ? 1 : groups;
  const int nx = dx ? xgroups * rb * xcb : 0;
  const int wcb = blocks(out, kColBlock);
  const int nw = (dw || db) ? groups * wcb : 0;
  const double flops = 2.0 * B * in * out * groups * ((dx ? 1 : 0) + (dw ? 1 : 0));
  gemm_flops_ += flops;
  if (y.i1) {
    // Fused ReLU: dL/dz = dL/dy where y > 0 (y > 0 exactly where z > 0),
    // written over y's own gradient, which nothing else reads. 0 + g gives
    // the bits of the separate relu node's gx += g into a zeroed gx.
    for_elems(int64_t(B) * ldy, [g = y.g, v = y.v](int64_t lo, int64_t hi) { relu_mask_grad<T>(g, v, lo, hi); });
  }
  run_tasks(nx + nw, flops, [&](int t) {
    if (t < nx) {
      const int q = t / (rb * xcb), r = (t / xcb) % rb, c = t % xcb;
      const int r0 = r * kRowBlock, nr = std::min(kRowBlock, B - r0);
      const int c0 = c * kColBlock, nc = std::min(kColBlock, in - c0);
      T* dxt = x.g + int64_t(r0) * ldx + q * in + c0;
      MatMap<T> DX(dxt, nr, nc, Eigen::OuterStride<>(ldx));
      const int q_begin = shared ? 0 : q, q_end = shared ? groups : q + 1;
      for (int g = q_begin; g < q_end; ++g) {
        const T* dyt = y.g + int64_t(r0) * ldy + g * out;
        const T* wt = w.v + (int64_t(g) * in + c0) * out;
        if (exact_tile<T>(nr, nc, out, dyt, ldy, 1, wt, 1, out, dxt, ldx, nullptr, false)) continue;
        CMatMap<T> DY(dyt, nr, out, Eigen::OuterStride<>(ldy));
        CMatMap<T> W(wt, nc, out, Eigen::OuterStride<>(out));
        DX.noalias() += DY * W.transpose();
      }
      return;
    }
    t -= nx;
    const int q = t / wcb, c = t % wcb;
    const int c0 = c * kColBlock, nc = std::min(kColBlock, out - c0);
    if (dw) {
      T* dwt = w.g + int64_t(q) * in * out + c0;
      const T* xt = x.v + (shared ? 0 : q * in);
      const T* dyt = y.g + q * out + c0;
      if (!exact_tile<T>(in, nc, B, xt, 1, ldx, dyt, ldy, 1, dwt, out, set_w ? kZeroRow<T> : nullptr, false)) {
        if (set_w)
          for (int i = 0; i < in; ++i) std::memset(dwt + int64_t(i) * out, 0, sizeof(T) * size_t(nc));
        MatMap<T> DW(dwt, in, nc, Eigen::OuterStride<>(out));
        CMatMap<T> X(xt, B, in, Eigen::OuterStride<>(ldx));
        CMatMap<T> DY(dyt, B, nc, Eigen::OuterStride<>(ldy));
        DW.noalias() += X.transpose() * DY;
      }
    }
    if (db) {
      T* dbv = b->g + q * out + c0;
      if (set_b) std::memset(dbv, 0, sizeof(T) * size_t(nc));
      for (int i = 0; i < B; ++i) {
        const T* dyr = y.g + int64_t(i) * ldy + q * out + c0;
        for (int j = 0; j < nc; ++j) dbv[j] += dyr[j];
      }
    }
  });
  if (set_w) nodes_[size_t(y.b)].unset = false;
  if (set_b) nodes_[size_t(y.c)].unset = false;
}

// ---------------------------------------------------------------- binary, broadcasting
namespace {
template <class T>
struct BinaryRule {
  // forward value and the two partial derivatives for op at (a, b)
  static T f(Op op, T a, T b) {
    switch (op) {
      case Op::Add: return a + b;
      case Op::Sub: return a - b;
      case Op::Mul: return a * b;
      default: return a <= b ? a : b;  // Min
    }
  }
  static T da(Op op, T a, T b) {
    switch (op) {
      case Op::Add: case Op::Sub: return T(1);
      case Op::Mul: return b;
      default: return a <= b ? T(1) : T(0);
    }
  }
  static T db(Op op, T a, T b) {
    switch (op) {
      case Op::Add: return T(1);
      case Op::Sub: return T(-1);
      case Op::Mul: return a;
      default: return a <= b ? T(0) : T(1);
    }
  }
};
}  // namespace

namespace {
// Same-shape fast path; pointers by value and restrict so each loop vectorises.
template <class T>
void binary_forward(Op op, const T* __restrict a, const T* __restrict b, T* __restrict y, int64_t lo, int64_t hi) {
  switch (op) {
    case Op::Add: for (int64_t i = lo; i < hi; ++i) y[i] = a[i] + b[i]; break;
    case Op::Sub: for (int64_t i = lo; i < hi; ++i) y[i] = a[i] - b[i]; break;
    case Op::Mul: for (int64_t i = lo; i < hi; ++i) y[i] = a[i] * b[i]; break;
    default: for (int64_t i = lo; i < hi; ++i) y[i] = a[i] <= b[i] ? a[i] : b[i];
  }
}
}  // namespace

template <class T>
typename Tape<T>::Id Tape<T>::binary(Op op, Id ai, Id bi) {
  const Node& a = node(ai);
  const Node& b = node(bi);
  const char* name = op == Op::Add ? "add" : op == Op::Sub ? "sub" : op == Op::Mul ? "mul" : "minimum";
  check((a.rows == b.rows || a.rows == 1 || b.rows == 1) && (a.cols == b.cols || a.cols == 1 || b.cols == 1),
        name, [&] { return "cannot broadcast " + shape(a.rows, a.cols) + " with " + shape(b.rows, b.cols); });
  Node y = make(op, std::max(a.rows, b.rows), std::max(a.cols, b.cols), a.needs_grad || b.needs_grad);
  y.a = ai; y.b = bi;
  const T* av = a.v;
  const T* bv = b.v;
  T* yv = y.v;
  if (a.rows == b.rows && a.cols == b.cols) {
    for_elems(y.rows * int64_t(y.cols), [=](int64_t lo, int64_t hi) { binary_forward<T>(op, av, bv, yv, lo, hi); });
  } else {
    const int64_t ars = a.rows == 1 ? 0 : a.cols, acs = a.cols == 1 ? 0 : 1;
    const int64_t brs = b.rows == 1 ? 0 : b.cols, bcs = b.cols == 1 ? 0 : 1;
    for (int i = 0; i < y.rows; ++i)
      for (int j = 0; j < y.cols; ++j)
        yv[int64_t(i) * y.cols + j] = BinaryRule<T>::f(op, av[i * ars + j * acs], bv[i * brs + j * bcs]);
  }
  return push(y);
}

template <class T>
void Tape<T>::back_binary(const Node& y) {
  const Node& a = node(y.a);
  const Node& b = node(y.b);
  const int64_t ars = a.rows == 1 ? 0 : a.cols, acs = a.cols == 1 ? 0 : 1;
  const int64_t brs = b.rows == 1 ? 0 : b.cols, bcs = b.cols == 1 ? 0 : 1;
  // One serial pass in row-major order: broadcast gradients sum in a fixed order.
  for (int i = 0; i < y.rows; ++i)
    for (int j = 0; j < y.cols; ++j) {
      const T dy = y.g[int64_t(i) * y.cols + j];
      const int64_t ia = i * ars + j * acs, ib = i * brs + j * bcs;
      if (a.needs_grad) a.g[ia] += dy * BinaryRule<T>::da(y.op, a.v[ia], b.v[ib]);
      if (b.needs_grad) b.g[ib] += dy * BinaryRule<T>::db(y.op, a.v[ia], b.v[ib]);
    }
}

template <class T> typename Tape<T>::Id Tape<T>::add(Id a, Id b) { return binary(Op::Add, a, b); }
template <class T> typename Tape<T>::Id Tape<T>::sub(Id a, Id b) { return binary(Op::Sub, a, b); }
template <class T> typename Tape<T>::Id Tape<T>::mul(Id a, Id b) { return binary(Op::Mul, a, b); }
template <class T> typename Tape<T>::Id Tape<T>::minimum(Id a, Id b) { return binary(Op::Min, a, b); }

// ---------------------------------------------------------------- unary, elementwise
// Each rule: value y = f(x) and dy/dx from (x, y); s0, s1 are the node's scalars.
namespace {
template <class T>
struct UnaryRule {
  static T f(Op op, T x, T s0, T s1) {
    switch (op) {
      case Op::Affine: return s0 * x + s1;
      case Op::Relu: return x > T(0) ? x : T(0);
      case Op::Tanh: return std::tanh(x);
      case Op::Sigmoid: return x >= T(0) ? T(1) / (T(1) + std::exp(-x)) : std::exp(x) / (T(1) + std::exp(x));
      case Op::Softplus: return std::max(x, T(0)) + std::log1p(std::exp(-std::abs(x)));
      case Op::Exp: return std::exp(x);
      case Op::Log: return std::log(x);
      case Op::Square: return x * x;
      default: return std::min(std::max(x, s0), s1);  // Clamp
    }
  }
  static T d(Op op, T x, T y, T s0, T s1) {
    switch (op) {
      case Op::Affine: return s0;
      case Op::Relu: return x > T(0) ? T(1) : T(0);
      case Op::Tanh: return T(1) - y * y;
      case Op::Sigmoid: return y * (T(1) - y);
      case Op::Softplus: return f(Op::Sigmoid, x, s0, s1);
      case Op::Exp: return y;
      case Op::Log: return T(1) / x;
      case Op::Square: return T(2) * x;
      default: return (x >= s0 && x <= s1) ? T(1) : T(0);  // Clamp
    }
  }
};

// Loops over [lo, hi) with every pointer passed by value and restrict-
// qualified (the tape never aliases a node's value and gradient buffers), so
// the compiler vectorises them; pointers captured by reference in a lambda
// would be reloaded on every iteration instead.
template <class T>
void unary_forward(Op op, const T* __restrict x, T* __restrict y, int64_t lo, int64_t hi, T s0, T s1) {
  switch (op) {
    case Op::Relu: for (int64_t i = lo; i < hi; ++i) y[i] = x[i] > T(0) ? x[i] : T(0); break;
    case Op::Affine: for (int64_t i = lo; i < hi; ++i) y[i] = s0 * x[i] + s1; break;
    case Op::Square: for (int64_t i = lo; i < hi; ++i) y[i] = x[i] * x[i]; break;
    default: for (int64_t i = lo; i < hi; ++i) y[i] = UnaryRule<T>::f(op, x[i], s0, s1);
  }
}

template <class T>
void unary_backward(Op op, T* __restrict gx, const T* __restrict x, const T* __restrict y,
                    const T* __restrict gy, int64_t lo, int64_t hi, T s0, T s1) {
  switch (op) {
    case Op::Relu: for (int64_t i = lo; i < hi; ++i) gx[i] += x[i] > T(0) ? gy[i] : T(0); break;
    case Op::Tanh: for (int64_t i = lo; i < hi; ++i) gx[i] += gy[i] * (T(1) - y[i] * y[i]); break;
    case Op::Affine: for (int64_t i = lo; i < hi; ++i) gx[i] += gy[i] * s0; break;
    case Op::Square: for (int64_t i = lo; i < hi; ++i) gx[i] += gy[i] * (T(2) * x[i]); break;
    default: for (int64_t i = lo; i < hi; ++i) gx[i] += gy[i] * UnaryRule<T>::d(op, x[i], y[i], s0, s1);
  }
}
}  // namespace

template <class T>
typename Tape<T>::Id Tape<T>::unary(Op op, Id xi) {
  const Node& x = node(xi);
  Node y = make(op, x.rows, x.cols, x.needs_grad);
  y.a = xi;
  return push(y);
}

template <class T>
void Tape<T>::back_unary(const Node& y) {
  const Node& x = node(y.a);
  if (!x.needs_grad) return;
  const Op op = y.op;
  T* gx = x.g;
  const T *xv = x.v, *yv = y.v, *gy = y.g;
  const T s0 = y.s0, s1 = y.s1;
  for_elems(y.rows * int64_t(y.cols),
            [=](int64_t lo, int64_t hi) { unary_backward<T>(op, gx, xv, yv, gy, lo, hi, s0, s1); });
}

#define ATACOM_UNARY(method, OPNAME, S0, S1)                                                   \
  template <class T>                                                                           \
  typename Tape<T>::Id Tape<T>::method {                                                       \
    const Id id = unary(Op::OPNAME, x);                                                        \
    Node& y = nodes_[size_t(id)];                                                              \
    y.s0 = S0;                                                                                 \
    y.s1 = S1;                                                                                 \
    const Node& xn = node(x);                                                                  \
    const T *xv = xn.v, s0 = y.s0, s1 = y.s1;                                                  \
    T* yv = y.v;                                                                               \
    for_elems(y.rows * int64_t(y.cols),                                                        \
              [=](int64_t lo, int64_t hi) { unary_forward<T>(Op::OPNAME, xv, yv, lo, hi, s0, s1); }); \
    return id;                                                                                 \
  }
ATACOM_UNARY(affine(Id x, T scale, T shift), Affine, scale, shift)
ATACOM_UNARY(relu(Id x), Relu, T(0), T(0))
ATACOM_UNARY(tanh(Id x), Tanh, T(0), T(0))
ATACOM_UNARY(sigmoid(Id x), Sigmoid, T(0), T(0))
ATACOM_UNARY(softplus(Id x), Softplus, T(0), T(0))
ATACOM_UNARY(exp(Id x), Exp, T(0), T(0))
ATACOM_UNARY(log(Id x), Log, T(0), T(0))
ATACOM_UNARY(square(Id x), Square, T(0), T(0))
ATACOM_UNARY(clamp(Id x, T lo, T hi), Clamp, lo, hi)
#undef ATACOM_UNARY

// ---------------------------------------------------------------- reductions
// Forward sums run in one fixed order (rows ascending, then columns).
template <class T>
typename Tape<T>::Id Tape<T>::reduce(Op op, Id xi, int axis) {
  const Node& x = node(xi);
  check(axis >= -1 && axis <= 1, op == Op::Sum ? "sum" : "mean", [] { return "axis must be -1, 0 or 1"; });
  const int rows = axis == 1 ? x.rows : 1, cols = axis == 0 ? x.cols : 1;
  Node y = make(op, rows, cols, x.needs_grad);
  y.a = xi; y.i0 = axis;
  const int64_t count = axis == -1 ? int64_t(x.rows) * x.cols : axis == 0 ? x.rows : x.cols;
  const T scale = op == Op::Mean ? T(1) / T(count) : T(1);
  std::fill(y.v, y.v + int64_t(rows) * cols, T(0));
  for (int i = 0; i < x.rows; ++i) {
    const T* xr = x.v + int64_t(i) * x.cols;
    if (axis == 0) {
      for (int j = 0; j < x.cols; ++j) y.v[j] += xr[j];
    } else {
      T s = 0;
      for (int j = 0; j < x.cols; ++j) s += xr[j];
      if (axis == 1) y.v[i] = s;
      else y.v[0] += s;
    }
  }
  for (int64_t k = 0; k < int64_t(rows) * cols; ++k) y.v[k] *= scale;
  return push(y);
}

template <class T>
void Tape<T>::back_reduce(const Node& y) {
  const Node& x = node(y.a);
  if (!x.needs_grad) return;
  const int axis = y.i0;
  const int64_t count = axis == -1 ? int64_t(x.rows) * x.cols : axis == 0 ? x.rows : x.cols;
  const T scale = y.op == Op::Mean ? T(1) / T(count) : T(1);
  for (int i = 0; i < x.rows; ++i)
    for (int j = 0; j < x.cols; ++j) {
      const T dy = axis == -1 ? y.g[0] : axis == 0 ? y.g[j] : y.g[i];
      x.g[int64_t(i) * x.cols + j] += dy * scale;
    }
}

template <class T> typename Tape<T>::Id Tape<T>::sum(Id x, int axis) { return reduce(Op::Sum, x, axis); }
template <class T> typename Tape<T>::Id Tape<T>::mean(Id x, int axis) { return reduce(Op::Mean, x, axis); }

// ---------------------------------------------------------------- concat / slice
template <class T>
typename Tape<T>::Id Tape<T>::concat(Id ai, Id bi) {
  const Node& a = node(ai);
  const Node& b = node(bi);
  check(a.rows == b.rows, "concat",
        [&] { return "row counts differ: " + shape(a.rows, a.cols) + " vs " + shape(b.rows, b.cols); });
  Node y = make(Op::Concat, a.rows, a.cols + b.cols, a.needs_grad || b.needs_grad);
  y.a = ai; y.b = bi;
  for (int i = 0; i < y.rows; ++i) {
    std::memcpy(y.v + int64_t(i) * y.cols, a.v + int64_t(i) * a.cols, sizeof(T) * size_t(a.cols));
    std::memcpy(y.v + int64_t(i) * y.cols + a.cols, b.v + int64_t(i) * b.cols, sizeof(T) * size_t(b.cols));
  }
  return push(y);
}

template <class T>
typename Tape<T>::Id Tape<T>::slice(Id xi, int c0, int c1) {
  const Node& x = node(xi);
  check(0 <= c0 && c0 < c1 && c1 <= x.cols, "slice", [&] {
    return "columns [" + std::to_string(c0) + ", " + std::to_string(c1) + ") outside " + shape(x.rows, x.cols);
  });
  Node y = make(Op::Slice, x.rows, c1 - c0, x.needs_grad);
  y.a = xi; y.i0 = c0; y.i1 = c1;
  for (int i = 0; i < y.rows; ++i)
    std::memcpy(y.v + int64_t(i) * y.cols, x.v + int64_t(i) * x.cols + c0, sizeof(T) * size_t(y.cols));
  return push(y);
}

// ---------------------------------------------------------------- tanh-squashed Gaussian log-prob
template <class T>
typename Tape<T>::Id Tape<T>::tanh_gauss_logp(Id mui, Id lsi, Id ui, T eps) {
  const Node& mu = node(mui);
  const Node& ls = node(lsi);
  const Node& u = node(ui);
  check(mu.rows == ls.rows && mu.rows == u.rows && mu.cols == ls.cols && mu.cols == u.cols, "tanh_gauss_logp",
        [] { return "mu, log_std and u must share one shape"; });
  Node y = make(Op::TanhGaussLogp, mu.rows, 1, mu.needs_grad || ls.needs_grad || u.needs_grad);
  y.a = mui; y.b = lsi; y.c = ui; y.s0 = eps;
  const T half_log_2pi = T(0.91893853320467274178);
  for (int i = 0; i < mu.rows; ++i) {
    T s = 0;
    for (int j = 0; j < mu.cols; ++j) {
      const int64_t k = int64_t(i) * mu.cols + j;
      const T z = (u.v[k] - mu.v[k]) * std::exp(-ls.v[k]);
      const T t = std::tanh(u.v[k]);
      s += T(-0.5) * z * z - ls.v[k] - half_log_2pi - std::log(T(1) - t * t + eps);
    }
    y.v[i] = s;
  }
  return push(y);
}

// d/dmu = z/sigma, d/dlog_std = z^2 - 1, d/du = -z/sigma + 2 t (1 - t^2) / (1 - t^2 + eps).
template <class T>
static void back_tanh_gauss_logp(const typename Tape<T>::Node& y, const typename Tape<T>::Node& mu,
                                 const typename Tape<T>::Node& ls, const typename Tape<T>::Node& u) {
  for (int i = 0; i < mu.rows; ++i) {
    const T dy = y.g[i];
    for (int j = 0; j < mu.cols; ++j) {
      const int64_t k = int64_t(i) * mu.cols + j;
      const T inv_sigma = std::exp(-ls.v[k]);
      const T z = (u.v[k] - mu.v[k]) * inv_sigma;
      if (mu.needs_grad) mu.g[k] += dy * z * inv_sigma;
      if (ls.needs_grad) ls.g[k] += dy * (z * z - T(1));
      if (u.needs_grad) {
        const T t = std::tanh(u.v[k]);
        const T one_t2 = T(1) - t * t;
        u.g[k] += dy * (-z * inv_sigma + T(2) * t * one_t2 / (one_t2 + y.s0));
      }
    }
  }
}

// ---------------------------------------------------------------- concat/slice backward and dispatch
template <class T>
void Tape<T>::backward(Id loss) {
  const Node& l = node(loss);
  check(l.rows == 1 && l.cols == 1, "backward", [&] { return "loss must be (1 x 1), got " + shape(l.rows, l.cols); });
  // A GradMode::Set leaf that some op other than a linear layer's weight or
  // bias consumes is cleared first and then added to like any other.
  for (const Node& n : nodes_) {
    if (n.op == Op::Leaf) continue;
    for (const Id in : {n.a, n.b, n.c}) {
      if (in < 0 || !nodes_[size_t(in)].unset) continue;
      if (n.op == Op::Linear && in != n.a) continue;
      Node& p = nodes_[size_t(in)];
      std::memset(p.g, 0, sizeof(T) * size_t(p.rows) * size_t(p.cols));
      p.unset = false;
    }
  }
  if (l.needs_grad) sweep(loss);
  // What no op wrote gets 0; staged leaves go to their owners.
  for (Id id = 0; id < Id(nodes_.size()); ++id) {
    Node& n = nodes_[size_t(id)];
    const size_t sz = size_t(n.rows) * size_t(n.cols);
    if (n.unset) std::memset(n.g, 0, sizeof(T) * sz), n.unset = false;
    if (!n.ext_g) continue;
    if (n.grad_mode == GradMode::Set) std::memcpy(n.ext_g, n.g, sizeof(T) * sz);
    else if (id <= loss)
      for (size_t k = 0; k < sz; ++k) n.ext_g[k] += n.g[k];
  }
}

template <class T>
void Tape<T>::sweep(Id loss) {
  const Node& l = node(loss);
  l.g[0] += T(1);
  for (Id id = loss; id >= 0; --id) {
    const Node& y = nodes_[size_t(id)];
    if (!y.needs_grad) continue;
    switch (y.op) {
      case Op::Leaf: break;
      case Op::Linear: back_linear(y); break;
      case Op::Add: case Op::Sub: case Op::Mul: case Op::Min: back_binary(y); break;
      case Op::Sum: case Op::Mean: back_reduce(y); break;
      case Op::Concat: {
        const Node& a = node(y.a);
        const Node& b = node(y.b);
        for (int i = 0; i < y.rows; ++i) {
          const T* gy = y.g + int64_t(i) * y.cols;
          if (a.needs_grad) for (int j = 0; j < a.cols; ++j) a.g[int64_t(i) * a.cols + j] += gy[j];
          if (b.needs_grad) for (int j = 0; j < b.cols; ++j) b.g[int64_t(i) * b.cols + j] += gy[a.cols + j];
        }
        break;
      }
      case Op::Slice: {
        const Node& x = node(y.a);
        if (!x.needs_grad) break;
        for (int i = 0; i < y.rows; ++i)
          for (int j = 0; j < y.cols; ++j) x.g[int64_t(i) * x.cols + y.i0 + j] += y.g[int64_t(i) * y.cols + j];
        break;
      }
      case Op::TanhGaussLogp: back_tanh_gauss_logp<T>(y, node(y.a), node(y.b), node(y.c)); break;
      default: back_unary(y); break;
    }
  }
}

template class Tape<float>;
template class Tape<double>;

}  // namespace atacom
