#include "kernels/redsdf_batch.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <mutex>
#include <thread>

#include <tbb/task_arena.h>

#include "atacom/parallel.hpp"

namespace atacom {

namespace {
using Map = MatMap<float>;
using CMap = CMatMap<float>;

// y = act(x W + b) for `rows` rows.
void layer_forward(const float* P, const RedsdfLayer& l, const float* x, int rows, float* y) {
  CMap X(x, rows, l.in, Eigen::OuterStride<>(l.in));
  CMap W(P + l.w, l.in, l.out, Eigen::OuterStride<>(l.out));
  Map Y(y, rows, l.out, Eigen::OuterStride<>(l.out));
  Y.noalias() = X * W;
  const float* b = P + l.b;
  for (int r = 0; r < rows; ++r) {
    float* yr = y + int64_t(r) * l.out;
    if (l.relu)
      for (int o = 0; o < l.out; ++o) yr[o] = std::max(yr[o] + b[o], 0.0f);
    else
      for (int o = 0; o < l.out; ++o) yr[o] += b[o];
  }
}

// gx (rows x cols) (=, or += when accumulate) (gy * relu'(y)) W^T[:, 0:cols];
// gy is masked in place.
void layer_backward(const float* P, const RedsdfLayer& l, const float* y, float* gy, int rows, float* gx, int cols,
                    bool accumulate) {
  if (l.relu)
    for (int64_t i = 0; i < int64_t(rows) * l.out; ++i)
      if (y[i] <= 0.0f) gy[i] = 0.0f;
  CMap G(gy, rows, l.out, Eigen::OuterStride<>(l.out));
  CMap W(P + l.w, cols, l.out, Eigen::OuterStride<>(l.out));  // the first `cols` input rows of W
  Map X(gx, rows, cols, Eigen::OuterStride<>(cols));
  if (accumulate)
    X.noalias() += G * W.transpose();
  else
    X.noalias() = G * W.transpose();
}

inline float sigmoidf(float x) { return 1.0f / (1.0f + std::exp(-x)); }
inline float softplusf(float x) { return std::max(x, 0.0f) + std::log1p(std::exp(-std::abs(x))); }
}  // namespace

RedsdfBatch::RedsdfBatch(const RedsdfModel& model) : m_(&model) {
  const RedsdfLayout& L = model.layout;
  if (model.params.size() != L.num_params) throw std::invalid_argument("RedsdfBatch: model parameters do not match its layout");
  size_t off = 0;
  max_width_ = model.arch.input_dim();
  for (const auto* v : {&L.trunk, &L.head, &L.side})
    for (const RedsdfLayer& l : *v) {
      act_off_.push_back(off);
      off += size_t(kRedsdfBlock) * l.out;
      max_width_ = std::max({max_width_, l.out, l.in});
    }
  const int nslots = std::max<int>({tbb::this_task_arena::max_concurrency(), int(std::thread::hardware_concurrency()), 1});
  slots_.resize(size_t(nslots) + 1);  // + the slot of threads outside the arena
  for (Slot& s : slots_) {
    s.x.assign(size_t(kRedsdfBlock) * model.arch.input_dim(), 0.0f);
    s.acts.assign(off, 0.0f);
    s.ga.assign(size_t(kRedsdfBlock) * max_width_, 0.0f);
    s.gb.assign(size_t(kRedsdfBlock) * max_width_, 0.0f);
    s.gs.assign(size_t(kRedsdfBlock) * model.arch.side_width, 0.0f);
    s.seed_f.assign(size_t(kRedsdfBlock), 0.0f);
    s.seed_b.assign(size_t(kRedsdfBlock) * 2, 0.0f);
  }
}

double RedsdfBatch::flops_per_point() const {
  // forward: every layer; backward: every layer but the first in full, the
  // first only for its 3 point columns.
  const RedsdfLayer& first = m_->layout.trunk.front();
  const double fwd = m_->layout.forward_macs();
  return 2.0 * (fwd + fwd - double(first.in) * first.out + 3.0 * first.out);
}

void RedsdfBatch::run_block(Slot& s, const float* p, const float* pose, bool pose_shared, int64_t lo, int rows,
                            float* d, float* grad, float* grad_pose) const {
  const RedsdfModel& M = *m_;
  const RedsdfLayout& L = M.layout;
  const float* P = M.params.data();
  const int in = M.arch.input_dim(), pd = M.arch.pose_dim;
  for (int r = 0; r < rows; ++r) {
    float* xr = s.x.data() + int64_t(r) * in;
    const float* pr = p + (lo + r) * 3;
    xr[0] = pr[0], xr[1] = pr[1], xr[2] = pr[2];
    const float* q = pd == 0 ? nullptr : pose + (pose_shared ? 0 : (lo + r) * pd);
    for (int k = 0; k < pd; ++k) xr[3 + k] = q[k];
  }
  // Forward.
  const size_t nt = L.trunk.size(), nh = L.head.size();
  auto act = [&](size_t i) { return s.acts.data() + act_off_[i]; };
  const float* x = s.x.data();
  for (size_t i = 0; i < nt; ++i) { layer_forward(P, L.trunk[i], x, rows, act(i)); x = act(i); }
  const float* t = x;
  for (size_t i = 0; i < nh; ++i) { layer_forward(P, L.head[i], x, rows, act(nt + i)); x = act(nt + i); }
  const float* f = x;  // (rows x 1)
  layer_forward(P, L.side[0], t, rows, act(nt + nh));
  layer_forward(P, L.side[1], act(nt + nh), rows, act(nt + nh + 1));
  const float* bb = act(nt + nh + 1);  // (rows x 2)
  // Blend, and the backward seeds dd/df (rows) and dd/d(b0, b1) (rows x 2).
  const float cx = float(M.arch.centre.x()), cy = float(M.arch.centre.y()), cz = float(M.arch.centre.z());
  float* sf = s.seed_f.data();
  float* sb = s.seed_b.data();
  for (int r = 0; r < rows; ++r) {
    const float* pr = p + (lo + r) * 3;
    const float dx = pr[0] - cx, dy = pr[1] - cy, dz = pr[2] - cz;
    const float n = std::sqrt(dx * dx + dy * dy + dz * dz);
    const float b0 = bb[2 * r], b1 = bb[2 * r + 1];
    const float sg0 = sigmoidf(b0), sg1 = sigmoidf(b1);
    const float alpha = softplusf(b0) + 1.0f, rho = sg1 + 0.5f;
    const float sigma = sigmoidf(alpha * (n - rho));
    const float fr = f[r];
    d[lo + r] = (1.0f - sigma) * fr + sigma * n;
    if (!grad) continue;
    const float ds = sigma * (1.0f - sigma) * (n - fr);  // dd/dsigma * dsigma/dz
    sf[r] = 1.0f - sigma;
    sb[2 * r] = ds * (n - rho) * sg0;
    sb[2 * r + 1] = -ds * alpha * sg1 * (1.0f - sg1);
    // The explicit dependence on n goes straight into grad; the network's part is added below.
    const float cn = (sigma + ds * alpha) / std::max(n, 1e-12f);
    float* g = grad + (lo + r) * 3;
    g[0] = cn * dx, g[1] = cn * dy, g[2] = cn * dz;
  }
  if (!grad) return;
  // Backward for the input gradient, ping-ponging between ga and gb.
  const int first_cols = grad_pose ? in : 3;
  float* ga = s.ga.data();
  float* gbuf = s.gb.data();
  auto other = [&](const float* cur) { return cur == ga ? gbuf : ga; };
  layer_backward(P, L.side[1], bb, sb, rows, s.gs.data(), L.side[1].in, false);
  float* cur = sf;
  for (size_t k = nh; k-- > 0;) {
    float* out = other(cur);
    layer_backward(P, L.head[k], act(nt + k), cur, rows, out, L.head[k].in, false);
    cur = out;
  }
  layer_backward(P, L.side[0], act(nt + nh), s.gs.data(), rows, cur, L.side[0].in, true);
  for (size_t k = nt; k-- > 0;) {
    float* out = other(cur);
    layer_backward(P, L.trunk[k], act(k), cur, rows, out, k == 0 ? first_cols : L.trunk[k].in, false);
    cur = out;
  }
  for (int r = 0; r < rows; ++r) {
    float* g = grad + (lo + r) * 3;
    const float* c = cur + int64_t(first_cols) * r;
    g[0] += c[0], g[1] += c[1], g[2] += c[2];
    if (grad_pose)
      for (int k = 0; k < pd; ++k) grad_pose[(lo + r) * pd + k] = c[3 + k];
  }
}

void RedsdfBatch::evaluate_range(const float* p, const float* pose, bool pose_shared, int64_t lo, int64_t hi,
                                 float* d, float* grad, float* grad_pose) {
  if (grad_pose && !grad) throw std::invalid_argument("RedsdfBatch::evaluate_range: grad_pose needs grad");
  auto run = [&](Slot& s) {
    for (int64_t b = lo; b < hi; b += kRedsdfBlock)
      run_block(s, p, pose, pose_shared, b, int(std::min<int64_t>(kRedsdfBlock, hi - b)), d, grad, grad_pose);
  };
  const int idx = tbb::this_task_arena::current_thread_index();
  if (idx >= 0 && size_t(idx) + 1 < slots_.size()) {
    run(slots_[size_t(idx)]);
  } else {
    // A thread outside the TBB arena (or beyond its slots): the shared last slot, one caller at a time.
    std::lock_guard<std::mutex> lock(external_mutex_);
    run(slots_.back());
  }
}

void RedsdfBatch::evaluate(const float* p, const float* pose, bool pose_shared, int64_t n, float* d, float* grad) {
  if (m_->arch.pose_dim > 0 && !pose) throw std::invalid_argument("RedsdfBatch::evaluate: the model needs a pose");
  parallel_blocks(n, 4 * kRedsdfBlock, [&](int64_t lo, int64_t hi) { evaluate_range(p, pose, pose_shared, lo, hi, d, grad); });
}

}  // namespace atacom
