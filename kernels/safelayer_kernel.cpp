// Batched SafeLayer: per env, the linearised rows g = dt J_q G,
// h = C - c - dt (J_q f + J_x xdot), then the QP of kernels/safelayer_qp.
// Most steps keep a_pi (no row would be crossed in one period), so the cost
// is dominated by forming g, which is k n (diagonal G) or k n m (dense G).
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/parallel.hpp"
#include "atacom/safelayer.hpp"
#include "kernels/safelayer_qp.hpp"

namespace atacom {

namespace {

constexpr int kBlockEnvs = 256;  // envs per parallel task (thread-count independent)

struct KernelScratch {
  safelayer_qp::Scratch qp;
  std::vector<double> g, h, r, a_pi, dtG, v;
  void setup(const SafeLayerModel& mod) {
    if (g.size() < size_t(mod.k) * mod.m) g.resize(size_t(mod.k) * mod.m);
    if (h.size() < size_t(mod.k)) h.resize(mod.k), r.resize(mod.k);
    if (dtG.size() < size_t(mod.m)) dtG.resize(mod.m);
    if (v.size() < size_t(mod.n)) v.resize(mod.n);
    if (a_pi.size() < size_t(mod.m)) a_pi.resize(mod.m);
    qp.setup(mod.m, mod.k);
  }
};

[[gnu::noinline]] KernelScratch& thread_scratch() {
  thread_local KernelScratch scratch;
  return scratch;
}

void check_batch(const SafeLayerModel& mod, const ProjectorBatch& B, const SafeLayerBatch& O) {
  const size_t N = static_cast<size_t>(B.N);
  const size_t gsz = mod.g_form == GForm::Diagonal ? size_t(mod.n) : size_t(mod.n) * mod.m;
  const bool in_ok = B.G.size() >= N * gsz && B.c.size() >= N * mod.k && B.Jq.size() >= N * mod.k * mod.n &&
                     B.Jx.size() >= N * mod.k * mod.p && B.xdot.size() >= N * mod.p && B.alpha.size() >= N * mod.m &&
                     (!mod.has_drift || B.f.size() >= N * mod.n);
  if (!in_ok) throw std::invalid_argument("safelayer: input batch sizes do not match the model (use ProjectorBatch of the same shapes)");
  if (O.N != B.N || O.a.size() != N * mod.m || O.status.size() != N)
    throw std::invalid_argument("safelayer: output batch does not match (use SafeLayerBatch(model, N))");
}

void solve_env(const SafeLayerModel& mod, const ProjectorBatch& B, SafeLayerBatch& O, int e, KernelScratch& S,
               bool store_rows) {
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  const double dt = mod.dt;
  uint32_t status = 0;
  double* a_pi = S.a_pi.data();
  const double* alpha = B.alpha.data() + size_t(e) * m;
  for (int j = 0; j < m; ++j) {
    if (std::isfinite(alpha[j])) {
      a_pi[j] = std::clamp(alpha[j], -1.0, 1.0);
    } else {
      a_pi[j] = 0.0;
      status |= kSafeLayerAlphaNonFinite;
    }
  }
  const double* G = B.G.data() + size_t(e) * (mod.g_form == GForm::Diagonal ? n : n * m);
  const double* Jq = B.Jq.data() + size_t(e) * k * n;
  const double* c = B.c.data() + size_t(e) * k;
  const double* f = mod.has_drift ? B.f.data() + size_t(e) * n : nullptr;
  const double* Jx = p ? B.Jx.data() + size_t(e) * k * p : nullptr;
  const double* xd = p ? B.xdot.data() + size_t(e) * p : nullptr;
  double* g = S.g.data();
  double* h = S.h.data();
  double* r = S.r.data();
  // Residuals at a_pi first, without forming g: r_i = c_i - C_i + J_q,i v +
  // dt J_x,i xdot with v = dt (f + G a_pi), k n multiply-adds instead of
  // k n m. Most steps keep a_pi (no row would be crossed within one period)
  // and never form the rows or enter the solver. A non-finite input makes
  // some residual non-finite (NaN propagates, Inf * 0 is NaN), so one check
  // on r covers f, G, c, J and xdot.
  double* v = S.v.data();
  for (int l = 0; l < n; ++l) {
    double s = f ? f[l] : 0.0;
    if (mod.g_form == GForm::Diagonal) {
      s += G[l] * a_pi[l];
    } else {
      for (int j = 0; j < m; ++j) s += G[size_t(l) * m + j] * a_pi[j];
    }
    v[l] = dt * s;
  }
  bool finite = true, keep = true;
  for (int i = 0; i < k; ++i) {
    const double* row = Jq + size_t(i) * n;
    double ri = c[i] - mod.threshold[i];
    for (int l = 0; l < n; ++l) ri += row[l] * v[l];
    double fx = 0.0;
    for (int q = 0; q < p; ++q) fx += Jx[size_t(i) * p + q] * xd[q];
    ri += dt * fx;
    r[i] = ri;
    finite = finite && std::isfinite(ri);
    keep = keep && ri <= kSafeLayerFeasTol;
  }
  if (finite && !keep) {
    double* dtG = S.dtG.data();
    if (mod.g_form == GForm::Diagonal)
      for (int j = 0; j < m; ++j) dtG[j] = dt * G[j];
    for (int i = 0; i < k; ++i) {
      const double* row = Jq + size_t(i) * n;
      double* gi = g + size_t(i) * m;
      double F = 0.0;
      if (mod.g_form == GForm::Diagonal) {
        for (int j = 0; j < m; ++j) gi[j] = row[j] * dtG[j];
      } else {
        std::fill_n(gi, m, 0.0);
        for (int l = 0; l < n; ++l) {
          const double jl = dt * row[l];
          for (int j = 0; j < m; ++j) gi[j] += jl * G[size_t(l) * m + j];
        }
      }
      if (f)
        for (int l = 0; l < n; ++l) F += row[l] * f[l];
      for (int q = 0; q < p; ++q) F += Jx[size_t(i) * p + q] * xd[q];
      h[i] = mod.threshold[i] - c[i] - dt * F;
    }
  }
  double* a = O.a.data() + size_t(e) * m;
  int iters = 0;
  uint8_t* rows = store_rows ? O.active_rows.data() + size_t(e) * k : nullptr;
  if (!finite) {
    std::fill_n(a, m, 0.0);
    status |= kSafeLayerModelNonFinite;
    if (rows) std::fill_n(rows, k, uint8_t{0});
  } else if (keep) {
    std::copy_n(a_pi, m, a);
  } else {
    const safelayer_qp::Result res = safelayer_qp::solve(m, k, g, h, a_pi, a, nullptr, S.qp);
    status |= res.status;
    iters = res.iterations;
    for (int i = 0; i < k; ++i) {
      double ri = -h[i];
      for (int j = 0; j < m; ++j) ri += g[size_t(i) * m + j] * a[j];
      r[i] = ri;
    }
  }
  double corr = 0.0;
  for (int j = 0; j < m; ++j) corr += (a[j] - a_pi[j]) * (a[j] - a_pi[j]);
  int active = 0;
  if (finite)
    for (int i = 0; i < k; ++i) {
      const bool act = r[i] >= -kSafeLayerFeasTol;
      active += act;
      if (rows) rows[i] = act;
    }
  O.correction[e] = std::sqrt(corr);
  O.active[e] = active;
  O.iterations[e] = iters;
  O.status[e] = status;
}

}  // namespace

void safelayer_range(const SafeLayerModel& mod, const ProjectorBatch& B, SafeLayerBatch& O, int begin, int end,
                     const SafeLayerOptions& opt) {
  if (begin >= end) return;
  KernelScratch& S = thread_scratch();
  S.setup(mod);
  for (int e = begin; e < end; ++e) solve_env(mod, B, O, e, S, opt.store_active_rows);
}

void safelayer_batch(const SafeLayerModel& mod, const ProjectorBatch& B, SafeLayerBatch& O,
                     const SafeLayerOptions& opt) {
  mod.validate();
  check_batch(mod, B, O);
  if (opt.store_active_rows && O.active_rows.size() != size_t(O.N) * mod.k) O.active_rows.assign(size_t(O.N) * mod.k, 0);
  if (!opt.parallel) {
    safelayer_range(mod, B, O, 0, B.N, opt);
    return;
  }
  parallel_blocks(B.N, kBlockEnvs, [&](int64_t lo, int64_t hi) {
    safelayer_range(mod, B, O, static_cast<int>(lo), static_cast<int>(hi), opt);
  });
}

uint32_t safelayer_solve(int m, int k, const double* g, const double* h, const double* a_pi, double* a, int* iterations,
                         double* mult) {
  KernelScratch& S = thread_scratch();
  S.qp.setup(m, k);
  const safelayer_qp::Result r = safelayer_qp::solve(m, k, g, h, a_pi, a, mult, S.qp);
  if (iterations) *iterations = r.iterations;
  return r.status;
}

}  // namespace atacom
