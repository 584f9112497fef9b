#include "train/adam.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <istream>
#include <ostream>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "atacom/parallel.hpp"

namespace atacom {

namespace {
constexpr int64_t kBlock = 1 << 14;  // elements per task; fixed

// Values that fall below the smallest normal number are set to 0. A
// parameter whose gradient is exactly 0 (a dead ReLU unit, a constant input)
// has m and v decaying geometrically; without the flush they sit in the
// subnormal range for thousands of updates, and arithmetic on subnormals
// takes a microcode assist (~100x slower). Seen in ATACOM-SAC runs: after
// ~80k steps Adam went from a few % to 40% of the update time and a 200k-step
// run took twice as long. Tiny gradients are flushed too (their squares are
// subnormal). Nothing else changes: such values are 0 next to eps = 1e-8.
template <class A>
void flush_subnormal(A& x) {
  using T = typename A::Scalar;
  x = (x.abs() < std::numeric_limits<T>::min()).select(T(0), x);
}
}

AdamConfig default_adam_config() { return AdamConfig{}; }

void to_json(nlohmann::json& j, const AdamConfig& c) {
  j = nlohmann::json{{"beta1", c.beta1}, {"beta2", c.beta2}, {"eps", c.eps}};
}

AdamConfig read_adam_config(const nlohmann::json& j, const std::string& section) {
  ConfigReader r(j, section);
  AdamConfig c = default_adam_config();
  r.get("beta1", c.beta1, range::closed_open(0.0, 1.0));
  r.get("beta2", c.beta2, range::closed_open(0.0, 1.0));
  r.get("eps", c.eps, range::positive());
  r.finish();
  return c;
}

void from_json(const nlohmann::json& j, AdamConfig& c) { c = read_adam_config(j, "adam"); }

template <class T>
void Adam<T>::step(T* p, const T* g, double lr) {
  ++t_;
  const T b1 = T(cfg_.beta1), b2 = T(cfg_.beta2), eps = T(cfg_.eps);
  const T step_size = T(lr / (1.0 - std::pow(cfg_.beta1, double(t_))));
  const T inv_sqrt_bc2 = T(1.0 / std::sqrt(1.0 - std::pow(cfg_.beta2, double(t_))));
  T* m = m_.data();
  T* v = v_.data();
  // Eigen array expressions: vectorised sqrt and division (a plain loop
  // calling std::sqrt stays scalar because of errno semantics).
  parallel_blocks(int64_t(m_.size()), kBlock, [&](int64_t lo, int64_t hi) {
    using A = Eigen::Array<T, Eigen::Dynamic, 1>;
    const Eigen::Index n = hi - lo;
    Eigen::Map<A> P(p + lo, n), M(m + lo, n), V(v + lo, n);
    Eigen::Map<const A> G(g + lo, n);
    M = b1 * M + (T(1) - b1) * G;
    V = b2 * V + (T(1) - b2) * G.square();
    flush_subnormal(M);
    flush_subnormal(V);
    P -= step_size * M / (V.sqrt() * inv_sqrt_bc2 + eps);
  });
}

namespace {
template <class T>
struct FusedCoeffs {
  T b1, b2, eps, step_size, inv_sqrt_bc2, ta, tb;
  bool zero_grads;
};

// The fused step on [lo, hi) as Eigen array expressions: the definition of
// its bits. Eigen takes the elements before the first aligned packet of each
// destination and after the last whole one on its scalar path, and there
// its sqrt is exact while the packet sqrt (EIGEN_FAST_MATH) is not, so which
// elements go which way is part of the result.
template <class T>
void fused_range_expr(T* p, T* g, T* m, T* v, T* target, int64_t lo, int64_t hi, const FusedCoeffs<T>& c) {
  using A = Eigen::Array<T, Eigen::Dynamic, 1>;
  const Eigen::Index n = hi - lo;
  Eigen::Map<A> P(p + lo, n), M(m + lo, n), V(v + lo, n), G(g + lo, n);
  flush_subnormal(G);
  M = c.b1 * M + (T(1) - c.b1) * G;
  V = c.b2 * V + (T(1) - c.b2) * G.square();
  flush_subnormal(M);
  flush_subnormal(V);
  P -= c.step_size * M / (V.sqrt() * c.inv_sqrt_bc2 + c.eps);
  if (c.zero_grads) G.setZero();
  if (target) {
    Eigen::Map<A> Tg(target + lo, n);
    Tg = c.ta * Tg + c.tb * P;
  }
}

// The same step, same bits, in chunks that stay in L1: the expressions
// make eight passes, and over a whole 2^14 block each pass streams from L2.
// Chunk boundaries sit on packet boundaries, so every element takes the
// path it takes over the whole block (a chunk is all packets, the block's
// scalar head and tail are run alone). That needs all five arrays on one
// alignment phase (the moments are 64-byte aligned, so aligned parameters,
// gradients and targets qualify); otherwise the block runs whole.
template <class T>
void fused_block(T* p, T* g, T* m, T* v, T* target, int64_t lo, int64_t hi, const FusedCoeffs<T>& c) {
  using Traits = Eigen::internal::packet_traits<T>;
  // Eigen aligns its packet loops to a whole packet (the packet's size for
  // every float and double packet).
  constexpr int64_t kLanes = Traits::Vectorizable ? Traits::size : 1;
  constexpr uintptr_t kAlign = uintptr_t(kLanes) * sizeof(T);
  constexpr int64_t kChunk = 512;
  static_assert(kChunk % kLanes == 0);
  const auto phase = [](const T* x) { return reinterpret_cast<uintptr_t>(x) % kAlign; };
  const uintptr_t ph = phase(p + lo);
  if (kLanes == 1 || ph % sizeof(T) != 0 || phase(g + lo) != ph || phase(m + lo) != ph || phase(v + lo) != ph ||
      (target && phase(target + lo) != ph)) {
    fused_range_expr(p, g, m, v, target, lo, hi, c);
    return;
  }
  const int64_t head = std::min<int64_t>(hi - lo, int64_t((kAlign - ph) % kAlign / sizeof(T)));
  const int64_t body = lo + head, end = body + (hi - body) / kLanes * kLanes;
  if (head > 0) fused_range_expr(p, g, m, v, target, lo, body, c);
  for (int64_t a = body; a < end; a += kChunk) fused_range_expr(p, g, m, v, target, a, std::min(end, a + kChunk), c);
  if (end < hi) fused_range_expr(p, g, m, v, target, end, hi, c);
}
}  // namespace

template <class T>
void Adam<T>::step_fused(T* p, T* g, double lr, T* target, double tau, Grads after) {
  ++t_;
  const FusedCoeffs<T> c{T(cfg_.beta1), T(cfg_.beta2), T(cfg_.eps),
                         T(lr / (1.0 - std::pow(cfg_.beta1, double(t_)))),
                         T(1.0 / std::sqrt(1.0 - std::pow(cfg_.beta2, double(t_)))), T(1.0 - tau), T(tau),
                         after == Grads::Zero};
  T* m = m_.data();
  T* v = v_.data();
  parallel_blocks(int64_t(m_.size()), kBlock, [&](int64_t lo, int64_t hi) {
    fused_block(p, g, m, v, target, lo, hi, c);
  });
}

template <class T>
void Adam<T>::save(std::ostream& out) const {
  bin::write_pod<int64_t>(out, t_);
  bin::write_vec(out, m_);
  bin::write_vec(out, v_);
}

template <class T>
void Adam<T>::load(std::istream& in) {
  const int64_t t = bin::read_pod<int64_t>(in, "adam.t");
  const auto n = static_cast<int64_t>(m_.size());
  bin::read_vec(in, m_, "adam.m", n);
  bin::read_vec(in, v_, "adam.v", n);
  t_ = t;
}

template <class T>
double clip_grad_norm(T* g, size_t n, double max_norm) {
  // 8 interleaved partial sums in a fixed pattern: vectorisable, and the
  // same bits for any thread count.
  double part[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  size_t i = 0;
  for (; i + 8 <= n; i += 8)
    for (int k = 0; k < 8; ++k) part[k] += double(g[i + size_t(k)]) * double(g[i + size_t(k)]);
  for (; i < n; ++i) part[0] += double(g[i]) * double(g[i]);
  const double norm = std::sqrt(((part[0] + part[1]) + (part[2] + part[3])) + ((part[4] + part[5]) + (part[6] + part[7])));
  if (max_norm > 0 && std::isfinite(norm) && norm > max_norm) {
    const T scale = T(max_norm / (norm + 1e-6));
    for (size_t j = 0; j < n; ++j) g[j] *= scale;
  }
  return norm;
}

template <class T>
void polyak_update(T* target, const T* source, size_t n, double tau) {
  const T a = T(1.0 - tau), b = T(tau);
  parallel_blocks(int64_t(n), kBlock, [&](int64_t lo, int64_t hi) {
    for (int64_t i = lo; i < hi; ++i) target[i] = a * target[i] + b * source[i];
  });
}

template class Adam<float>;
template class Adam<double>;
template double clip_grad_norm<float>(float*, size_t, double);
template double clip_grad_norm<double>(double*, size_t, double);
template void polyak_update<float>(float*, const float*, size_t, double);
template void polyak_update<double>(double*, const double*, size_t, double);

}  // namespace atacom
