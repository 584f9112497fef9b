#include "train/redsdf_loss.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace atacom {

template <class T>
RedsdfLoss<T>::RedsdfLoss(const RedsdfArch& arch, int max_batch)
    : arch_(arch), layout_(arch), max_batch_(max_batch) {
  if (max_batch < 1) throw std::invalid_argument("RedsdfLoss: max_batch must be positive");
  const size_t B = size_t(max_batch);
  for (const auto* v : {&layout_.trunk, &layout_.head, &layout_.side})
    for (const RedsdfLayer& l : *v)
      if (l.relu) mask_.emplace_back(B * size_t(l.out), T(0));
  for (int k = 0; k < 3; ++k) {
    unit_[k].assign(B, T(0));
    nrm_[k].assign(B, T(0));
    onehot_[k].assign(size_t(arch.input_dim()), T(0));
    onehot_[k][size_t(k)] = T(1);
  }
  has_.assign(B, T(0));
  const size_t layers = layout_.trunk.size() + layout_.head.size() + layout_.side.size();
  wid_.reserve(layers);
  out_.reserve(layers);
}

template <class T>
typename RedsdfLoss<T>::Terms RedsdfLoss<T>::record(Tape<T>& tp, T* P, T* G, const RedsdfLossBatch<T>& b, T gamma,
                                                    T align) {
  if (b.B < 1 || b.B > max_batch_)
    throw std::invalid_argument("RedsdfLoss: batch of " + std::to_string(b.B) + " points, scratch holds 1 to " +
                                std::to_string(max_batch_));
  const int B = b.B, IN = arch_.input_dim();
  wid_.clear();
  out_.clear();
  auto lin = [&](const RedsdfLayer& l, Id in) {
    const Id W = tp.leaf(P + l.w, G + l.w, l.in, l.out);
    const Id bias = tp.leaf(P + l.b, G + l.b, 1, l.out);
    const Id o = tp.linear(in, W, bias);
    const Id y = l.relu ? tp.relu(o) : o;
    wid_.push_back(W);
    out_.push_back(y);
    return y;
  };
  // The forward pass and the first two terms: node for node the graph of the
  // loss before the alignment term existed (bitwise the same training).
  Id h = tp.constant(b.x, B, IN);
  for (const auto& l : layout_.trunk) h = lin(l, h);
  const Id t = h;
  for (const auto& l : layout_.head) h = lin(l, h);
  const Id f = h;
  const Id bb = lin(layout_.side[1], lin(layout_.side[0], t));
  const Id b0 = tp.slice(bb, 0, 1);
  const Id alpha = tp.affine(tp.softplus(b0), T(1), T(1));
  const Id b1 = tp.slice(bb, 1, 2);
  const Id rho = tp.affine(tp.sigmoid(b1), T(1), T(0.5));
  const Id nn = tp.constant(b.radius, B, 1);
  const Id n_rho = tp.sub(nn, rho);
  const Id sigma = tp.sigmoid(tp.mul(alpha, n_rho));
  const Id n_f = tp.sub(nn, f);
  const Id d = tp.add(f, tp.mul(sigma, n_f));
  const Id err = tp.sub(d, tp.constant(b.y, B, 1));
  const Id wc = tp.constant(b.w, B, 1);
  Terms out;
  out.wmse = tp.mean(tp.mul(wc, tp.square(err)));
  out.rho_mean = tp.mean(rho);
  out.loss = tp.add(out.wmse, tp.affine(out.rho_mean, gamma, T(0)));
  if (!(align > T(0))) return out;

  // Constants of this batch: unit radial vectors, unit normals, which count.
  for (int i = 0; i < B; ++i) {
    const T r = b.radius[i];
    for (int k = 0; k < 3; ++k)
      unit_[k][size_t(i)] = r > T(0) ? (b.x[size_t(i) * IN + k] - T(arch_.centre(k))) / r : T(0);
    const T* n = b.normal + 3 * size_t(i);
    const T len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const bool has = b.has_normal[i] != T(0) && len > T(1e-6);
    for (int k = 0; k < 3; ++k) nrm_[k][size_t(i)] = has ? n[k] / len : T(0);
    has_[size_t(i)] = has ? T(1) : T(0);
    out.normals += has;
  }
  if (out.normals == 0) return out;
  // ReLU masks of this forward pass (y > 0 exactly where the pre-activation is).
  {
    size_t li = 0, mi = 0;
    for (const auto* v : {&layout_.trunk, &layout_.head, &layout_.side})
      for (const RedsdfLayer& l : *v) {
        const Id y = out_[li++];
        if (!l.relu) continue;
        const T* yv = tp.node(y).v;
        T* m = mask_[mi++].data();
        for (size_t j = 0; j < size_t(B) * size_t(l.out); ++j) m[j] = yv[j] > T(0) ? T(1) : T(0);
      }
  }
  // Blend derivatives shared by the three axes.
  const Id dalpha_db0 = tp.sigmoid(b0);                                                       // softplus'
  const Id drho_db1 = tp.mul(tp.affine(rho, T(1), T(-0.5)), tp.affine(rho, T(-1), T(1.5)));  // s (1 - s)
  const Id one_sigma = tp.affine(sigma, T(-1), T(1));
  const Id dsigma_dz = tp.mul(sigma, one_sigma);
  Id gg = -1, ng = -1;
  for (int k = 0; k < 3; ++k) {
    size_t li = 0, mi = 0;
    auto tangent = [&](const RedsdfLayer& l, Id in) {
      Id o = tp.linear(in, wid_[li++], -1);
      if (l.relu) o = tp.mul(o, tp.constant(mask_[mi++].data(), B, l.out));
      return o;
    };
    Id tk = tp.constant(onehot_[k].data(), 1, IN);  // d x / d p_k; the first layer broadcasts it over the batch
    for (const auto& l : layout_.trunk) tk = tangent(l, tk);
    const Id tt = tk;
    for (const auto& l : layout_.head) tk = tangent(l, tk);
    const Id tf = tk;
    const Id tb = tangent(layout_.side[1], tangent(layout_.side[0], tt));
    const Id u = tp.constant(unit_[k].data(), B, 1);  // d n / d p_k
    const Id dalpha = tp.mul(dalpha_db0, tp.slice(tb, 0, 1));
    const Id drho = tp.mul(drho_db1, tp.slice(tb, 1, 2));
    // z = alpha (n - rho), d = f + sigma(z) (n - f).
    const Id dz = tp.add(tp.mul(dalpha, n_rho), tp.mul(alpha, tp.sub(u, drho)));
    const Id g = tp.add(tp.add(tp.mul(one_sigma, tf), tp.mul(sigma, u)), tp.mul(tp.mul(dsigma_dz, dz), n_f));
    const Id g2 = tp.square(g);
    const Id nk_g = tp.mul(tp.constant(nrm_[k].data(), B, 1), g);
    gg = k ? tp.add(gg, g2) : g2;
    ng = k ? tp.add(ng, nk_g) : nk_g;
  }
  // sin^2 = 1 - (n.g)^2 / |g|^2 (|n| = 1); the tape has no division: 1/x = exp(-log x).
  const Id inv_gg = tp.exp(tp.affine(tp.log(tp.affine(gg, T(1), T(1e-12))), T(-1), T(0)));
  const Id sin2 = tp.affine(tp.mul(tp.square(ng), inv_gg), T(-1), T(1));
  out.align = tp.affine(tp.sum(tp.mul(tp.constant(has_.data(), B, 1), sin2)), T(1) / T(out.normals), T(0));
  out.loss = tp.add(out.loss, tp.affine(out.align, align, T(0)));
  return out;
}

template class RedsdfLoss<float>;
template class RedsdfLoss<double>;

}  // namespace atacom
