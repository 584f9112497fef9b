// Batched SafeLayer: per env, the linearised rows g = dt J_q G,
// h = C - c - dt (J_q f + J_x xdot), then the QP of kernels/safelayer_qp.
// Most steps keep a_pi (no row would be crossed in one period), so the
// first pass screens kLanes envs at once, one per vector lane (the rows'
// residuals at a_pi, k n multiply-adds per env); only the envs with a
// violated row form g (k n or k n m) and enter the scalar solver.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/parallel.hpp"
#include "atacom/safelayer.hpp"
#include "kernels/lanes.hpp"
#include "kernels/safelayer_qp.hpp"

namespace atacom {

namespace {

constexpr int kPrefetchBlocks = 2;  // lane blocks ahead
// Software prefetch only for envs with more input than this: consecutive
// envs' rows are one sequential stream per array, which the hardware
// prefetcher follows when an env's rows are short. Measured (Xeon, 2 MiB L2,
// nice-d, loaded): nav (392 B per env) is ~10% faster without it at
// N = 16384 and 65536; table (2.3 KB per env) is 1.5x faster with it.
constexpr size_t kPrefetchMinEnvBytes = 1024;

struct KernelScratch {
  safelayer_qp::Scratch qp;
  std::vector<double> g, h, r, a_pi, dtG;
  // lane block: a_pi (m), v (n), residuals (k), inputs J_q, f, G, J_x, xdot
  std::vector<lanes::vd> l_api, l_v, l_r, l_in;
  void setup(const SafeLayerModel& mod) {
    const size_t n = mod.n, m = mod.m, k = mod.k, p = mod.p;
    if (l_api.size() < m) l_api.resize(m);
    if (l_v.size() < n) l_v.resize(n);
    if (l_r.size() < k) l_r.resize(k);
    const size_t in = k * n + n + (mod.g_form == GForm::Diagonal ? n : n * m) + k * p + p;
    if (l_in.size() < in) l_in.resize(in);
    if (g.size() < size_t(mod.k) * mod.m) g.resize(size_t(mod.k) * mod.m);
    if (h.size() < size_t(mod.k)) h.resize(mod.k), r.resize(mod.k);
    if (dtG.size() < size_t(mod.m)) dtG.resize(mod.m);
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

// Lane block of up to kLanes envs [lo, lo + count): a_pi, and the rows'
// residuals at a_pi without forming g, r_i = c_i - C_i + J_q,i v + dt J_x,i
// xdot with v = dt (f + G a_pi) (k n multiply-adds instead of k n m), one
// env per vector lane. Most steps keep a_pi (no row would be crossed within
// one period) and end here: the solver and the rows g are only formed for
// the other lanes. A non-finite input makes some residual non-finite (NaN
// propagates, Inf * 0 is NaN), so one check on r covers f, G, c, J and xdot.
// Idle lanes repeat the last env. Bit masks per lane: keep, finite, alpha bad.
struct LaneScreen {
  uint32_t keep = 0, finite = 0, alpha_bad = 0;
  int active[lanes::kLanes];  // rows active at a_pi (r_i >= -tol), for the kept lanes
};

LaneScreen screen_lanes(const SafeLayerModel& mod, const ProjectorBatch& B, int lo, int count, KernelScratch& S) {
  using lanes::vd;
  using lanes::vm;
  constexpr int L = lanes::kLanes;
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  const bool diag = mod.g_form == GForm::Diagonal;
  const int gsz = diag ? n : n * m;
  const double dt = mod.dt;
  vd* api = S.l_api.data();
  vd* v = S.l_v.data();
  vd* r = S.l_r.data();
  vd* T = S.l_in.data();  // transposed inputs, reused per array
  const double* src[L];
  auto gather = [&](const double* base, int per_env, vd* dst) {
    for (int l = 0; l < L; ++l) src[l] = base + size_t(lo + std::min(l, count - 1)) * per_env;
    lanes::gather_rows(src, per_env, dst);
  };
  vm bad = vm{};
  gather(B.alpha.data(), m, api);
  for (int j = 0; j < m; ++j) {
    const vd al = api[j];
    const vm fin = (al - al) == 0.0;
    bad |= ~fin;
    api[j] = lanes::vclamp(lanes::vsel(fin, al, vd{}), -1.0, 1.0);
  }
  vd* f = T + size_t(k) * n;  // after J_q's slot
  vd* Gt = f + n;
  if (mod.has_drift) gather(B.f.data(), n, f);
  gather(B.G.data(), gsz, Gt);
  for (int l = 0; l < n; ++l) {
    vd s = mod.has_drift ? f[l] : vd{};
    if (diag) {
      s += Gt[l] * api[l];
    } else {
      for (int j = 0; j < m; ++j) s += Gt[size_t(l) * m + j] * api[j];
    }
    v[l] = dt * s;
  }
  gather(B.c.data(), k, r);
  gather(B.Jq.data(), k * n, T);
  vd* Jx = Gt + gsz;
  vd* xd = Jx + size_t(k) * p;
  if (p) {
    gather(B.Jx.data(), k * p, Jx);
    gather(B.xdot.data(), p, xd);
  }
  // Prefetch every input of the block kPrefetchBlocks ahead (long rows only,
  // kPrefetchMinEnvBytes): at large N the batch streams from memory and eight
  // envs' long rows at once defeat the hardware prefetcher. Spread over the row loop so the misses do not queue
  // up at once; the solver's work on this block's other envs hides them.
  struct Range {
    const char *p, *end;
  } pf[7];  // J_q, c, G, alpha, f, J_x, xdot
  int npf = 0, cur = 0, pf_per_row = 0;
  const int ahead = lo + kPrefetchBlocks * L;
  const size_t env_bytes = sizeof(double) * (size_t(k) * (n + p) + gsz + k + m + (mod.has_drift ? n : 0) + p);
  if (env_bytes > kPrefetchMinEnvBytes && ahead + L <= B.N) {
    auto add = [&](const double* base, size_t per_env) {
      if (per_env == 0) return;
      pf[npf++] = {reinterpret_cast<const char*>(base + size_t(ahead) * per_env),
                   reinterpret_cast<const char*>(base + size_t(ahead + L) * per_env)};
    };
    add(B.Jq.data(), size_t(k) * n);
    add(B.c.data(), k);
    add(B.G.data(), gsz);
    add(B.alpha.data(), m);
    if (mod.has_drift) add(B.f.data(), n);
    if (p) add(B.Jx.data(), size_t(k) * p), add(B.xdot.data(), p);
    size_t lines = 0;
    for (int t = 0; t < npf; ++t) lines += size_t(pf[t].end - pf[t].p) / 64 + 1;
    pf_per_row = int(lines / size_t(k)) + 1;
  }
  auto prefetch = [&](int count_lines) {
    while (count_lines > 0 && cur < npf) {
      if (pf[cur].p >= pf[cur].end) {
        ++cur;
        continue;
      }
      __builtin_prefetch(pf[cur].p, 0, 2);
      pf[cur].p += 64;
      --count_lines;
    }
  };
  vm fin = ~vm{}, keep = ~vm{}, active = vm{};
  for (int i = 0; i < k; ++i) {
    prefetch(pf_per_row);
    vd ri = r[i] - mod.threshold[i];
    for (int l = 0; l < n; ++l) ri += T[size_t(i) * n + l] * v[l];
    vd fx = vd{};
    for (int q = 0; q < p; ++q) fx += Jx[size_t(i) * p + q] * xd[q];
    ri += dt * fx;
    r[i] = ri;
    fin &= (ri - ri) == 0.0;
    keep &= ri <= kSafeLayerFeasTol;
    active -= ri >= -kSafeLayerFeasTol;
  }
  LaneScreen out;
  for (int l = 0; l < count; ++l) {
    out.keep |= uint32_t(keep[l] != 0) << l;
    out.finite |= uint32_t(fin[l] != 0) << l;
    out.alpha_bad |= uint32_t(bad[l] != 0) << l;
    out.active[l] = static_cast<int>(active[l]);
  }
  return out;
}

// Writes env e's outputs from its answer a (already in O.a) and the rows'
// residuals r at a.
void finish_env(const SafeLayerModel& mod, SafeLayerBatch& O, int e, const double* a_pi, const double* r, bool finite,
                int iters, uint32_t status, bool store_rows) {
  const int m = mod.m, k = mod.k;
  const double* a = O.a.data() + size_t(e) * m;
  uint8_t* rows = store_rows ? O.active_rows.data() + size_t(e) * k : nullptr;
  double corr = 0.0;
  for (int j = 0; j < m; ++j) corr += (a[j] - a_pi[j]) * (a[j] - a_pi[j]);
  int active = 0;
  if (finite) {
    for (int i = 0; i < k; ++i) {
      const bool act = r[i] >= -kSafeLayerFeasTol;
      active += act;
      if (rows) rows[i] = act;
    }
  } else if (rows) {
    std::fill_n(rows, k, uint8_t{0});
  }
  O.correction[e] = std::sqrt(corr);
  O.active[e] = active;
  O.iterations[e] = iters;
  O.status[e] = status;
}

// Env e, some row violated at a_pi (finite inputs): the rows g = dt J_q G,
// h = C - c - dt (J_q f + J_x xdot), then the QP.
void solve_env(const SafeLayerModel& mod, const ProjectorBatch& B, SafeLayerBatch& O, int e, const double* a_pi,
               uint32_t status, KernelScratch& S, bool store_rows) {
  const int n = mod.n, m = mod.m, k = mod.k, p = mod.p;
  const double dt = mod.dt;
  const double* G = B.G.data() + size_t(e) * (mod.g_form == GForm::Diagonal ? n : n * m);
  const double* Jq = B.Jq.data() + size_t(e) * k * n;
  const double* c = B.c.data() + size_t(e) * k;
  const double* f = mod.has_drift ? B.f.data() + size_t(e) * n : nullptr;
  const double* Jx = p ? B.Jx.data() + size_t(e) * k * p : nullptr;
  const double* xd = p ? B.xdot.data() + size_t(e) * p : nullptr;
  double* g = S.g.data();
  double* h = S.h.data();
  double* r = S.r.data();
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
      // Summed in a register per column (accumulating into gi[j] in memory
      // chained every multiply-add through a store; same order, same bits).
      for (int j = 0; j < m; ++j) {
        double s = 0.0;
        for (int l = 0; l < n; ++l) s += (dt * row[l]) * G[size_t(l) * m + j];
        gi[j] = s;
      }
    }
    if (f)
      for (int l = 0; l < n; ++l) F += row[l] * f[l];
    for (int q = 0; q < p; ++q) F += Jx[size_t(i) * p + q] * xd[q];
    h[i] = mod.threshold[i] - c[i] - dt * F;
  }
  double* a = O.a.data() + size_t(e) * m;
  const safelayer_qp::Result res = safelayer_qp::solve(m, k, g, h, a_pi, a, nullptr, S.qp);
  for (int i = 0; i < k; ++i) {
    double ri = -h[i];
    for (int j = 0; j < m; ++j) ri += g[size_t(i) * m + j] * a[j];
    r[i] = ri;
  }
  finish_env(mod, O, e, a_pi, r, true, res.iterations, status | res.status, store_rows);
}

}  // namespace

void safelayer_range(const SafeLayerModel& mod, const ProjectorBatch& B, SafeLayerBatch& O, int begin, int end,
                     const SafeLayerOptions& opt) {
  if (begin >= end) return;
  KernelScratch& S = thread_scratch();
  S.setup(mod);
  const int m = mod.m, k = mod.k;
  double* a_pi = S.a_pi.data();
  double* r = S.r.data();
  for (int lo = begin; lo < end; lo += lanes::kLanes) {
    const int count = std::min(lanes::kLanes, end - lo);
    const LaneScreen sc = screen_lanes(mod, B, lo, count, S);
    const uint32_t all = (1u << count) - 1u;
    uint32_t pending = all;  // lanes still to write one by one
    if (count == lanes::kLanes && !opt.store_active_rows) {
      // Whole block as if every env kept a_pi, in vector stores (the envs'
      // outputs are contiguous); the lanes below overwrite their envs.
      double* dst[lanes::kLanes];
      for (int l = 0; l < lanes::kLanes; ++l) dst[l] = O.a.data() + size_t(lo + l) * m;
      lanes::scatter_rows(S.l_api.data(), m, dst);
      for (int l = 0; l < lanes::kLanes; ++l) {
        O.correction[size_t(lo) + l] = 0.0;
        O.active[size_t(lo) + l] = sc.active[l];
        O.iterations[size_t(lo) + l] = 0;
        O.status[size_t(lo) + l] = (sc.alpha_bad >> l & 1) ? kSafeLayerAlphaNonFinite : 0u;
      }
      pending = ~(sc.keep & sc.finite) & all;
    }
    for (; pending; pending &= pending - 1) {
      const int l = __builtin_ctz(pending);
      const int e = lo + l;
      for (int j = 0; j < m; ++j) a_pi[j] = S.l_api[j][l];
      const uint32_t status = (sc.alpha_bad >> l & 1) ? kSafeLayerAlphaNonFinite : 0u;
      double* a = O.a.data() + size_t(e) * m;
      if (!(sc.finite >> l & 1)) {
        std::fill_n(a, m, 0.0);
        finish_env(mod, O, e, a_pi, r, false, 0, status | kSafeLayerModelNonFinite, opt.store_active_rows);
      } else if (sc.keep >> l & 1) {
        std::copy_n(a_pi, m, a);
        O.correction[e] = 0.0;
        O.active[e] = sc.active[l];
        O.iterations[e] = 0;
        O.status[e] = status;
        if (opt.store_active_rows)
          for (int i = 0; i < k; ++i) O.active_rows[size_t(e) * k + i] = S.l_r[i][l] >= -kSafeLayerFeasTol;
      } else {
        solve_env(mod, B, O, e, a_pi, status, S, opt.store_active_rows);
      }
    }
  }
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
  parallel_blocks(B.N, kEnvBlock, [&](int64_t lo, int64_t hi) {
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
