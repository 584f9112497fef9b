// Throughput of the batched ATACOM projector: projections per second.
//
// One JSON line per configuration: N in {1, 64, 1024, 16384}, k in {5, 34,
// 100}, m in {2, 7}, threads in {1, 2}. Systems are generic: dense G
// (n = m = 7, or n = 3 for m = 2, the differential drive), drift f on, no
// uncontrollable state. Extra lines measure the arm's diagonal G and the
// machine's float64 FMA peak, so "gflops" can be read as a share of peak.
//
// Usage: bench_projector [--quick | --bound-pairs R | --bound-calls RULE C]
//   --bound-pairs R: only the arm's case (diagonal G, a only, N = 16384,
//   1 thread), the bound rules tangent_scale and correction_first measured
//   in turn, R rounds (issue 31).
//   --bound-calls RULE C: the same case, C calls with one rule and no
//   timing, for instruction counts (perf stat -e instructions:u).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "bench_common.hpp"


using namespace atacom;

namespace {

// Floating-point operations per projection, counted from the kernel's loops
// (multiply-adds count 2): J_G = J_q G, F = J_q f, the QR of [I; A^-1 J_G]
// with its right-hand side, three triangular solves, plus about 24 flops per
// row for the slack rate (exp polynomial, reciprocal) and scaling. The slack
// controls u_s = -A^-1 (r + J_q (G a)) are counted separately: envs skip them.
double flops_per_projection(int n, int m, int k, bool dense_g, bool drift) {
  const double fma = (dense_g ? double(k) * n * m : double(k) * m) + (drift ? double(k) * n : 0.0) +
                     double(k) * m * (m + 2) /* QR */ + 1.5 * m * m /* solves */;
  const double other = double(k) * m /* row scaling */ + 24.0 * k + 6.0 * m;
  return 2.0 * fma + other;
}
double flops_slack_controls(int n, int m, int k, bool dense_g) {
  return 2.0 * (double(k) * n + (dense_g ? double(n) * m : double(n))) + 2.0 * k;
}

void fill(const ProjectorModel& mod, ProjectorBatch& B, uint64_t seed) {
  Rng rng(seed, 0);
  for (auto& v : B.f) v = rng.normal();
  for (auto& v : B.G) v = mod.g_form == GForm::Diagonal ? rng.uniform(0.5, 2.0) : rng.normal();
  for (auto& v : B.c) v = rng.uniform(-1.0, 0.05);  // a mix of inactive, active and violated rows
  for (auto& v : B.Jq) v = rng.normal();
  for (auto& v : B.alpha) v = rng.uniform(-1.0, 1.0);
}

// The bound rules in alternating rounds, so a shared host's load drifts over all alike.
int bound_pairs(int rounds, const char* only = nullptr, int calls = 0) {
  set_num_threads(1);
  ProjectorModel mod = default_projector_model(7, 7, 34, 0);
  mod.g_form = GForm::Diagonal;
  mod.has_drift = false;
  ProjectorBatch B(mod, 16384);
  fill(mod, B, 2);
  if (only) {
    mod.bounds = parse_bound_rule(only);
    for (int c = 0; c < calls; ++c) project_batch(mod, B, {.store_slack = false});
    return 0;
  }
  const char* names[] = {"tangent_scale", "correction_first"};
  for (int r = 0; r < rounds; ++r) {
    for (int v = 0; v < 2; ++v) {
      mod.bounds = v == 0 ? BoundRule::TangentScale : BoundRule::CorrectionFirst;
      const double t = bench::best_seconds_per_call([&] { project_batch(mod, B, {.store_slack = false}); }, 3, 0.1);
      int out = 0;
      for (uint32_t st : B.status) out += (st & kStatusBiasOutOfBounds) != 0;
      bench::emit({{"bench", "projector_bounds"}, {"N", 16384}, {"k", 34}, {"m", 7}, {"G", "diagonal"},
                   {"slack_out", false}, {"threads", 1}, {"round", r}, {"bounds", names[v]},
                   {"bias_out_share", double(out) / 16384}, {"per_s", 16384 / t}});
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 2 && std::strcmp(argv[1], "--bound-pairs") == 0) return bound_pairs(std::max(1, std::atoi(argv[2])));
  if (argc > 3 && std::strcmp(argv[1], "--bound-calls") == 0)
    return bound_pairs(1, argv[2], std::max(0, std::atoi(argv[3])));
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const std::string cpu = bench::cpu_name();
  set_num_threads(1);
  const double peak1 = bench::measure_f64_peak_gflops_one_core();
  bench::emit({{"bench", "f64_fma_peak"}, {"threads", 1}, {"gflops", peak1}, {"cpu", cpu}});

  const int Ns[] = {1, 64, 1024, 16384};
  const int ks[] = {5, 34, 100};
  const int ms[] = {2, 7};
  const int threads_list[] = {1, 2};
  for (int m : ms) {
    for (int k : ks) {
      for (int N : Ns) {
        if (quick && N != 16384) continue;
        const int n = m == 2 ? 3 : m;
        ProjectorModel mod = default_projector_model(n, m, k, 0);
        ProjectorBatch B(mod, N);
        fill(mod, B, 1);
        for (int threads : threads_list) {
          set_num_threads(threads);
          const double t = bench::best_seconds_per_call([&] { project_batch(mod, B); }, quick ? 3 : 5, 0.1);
          const double per_s = N / t;
          const double flops = flops_per_projection(n, m, k, true, true) + flops_slack_controls(n, m, k, true);
          bench::emit({{"bench", "projector"}, {"N", N}, {"k", k}, {"m", m}, {"n", n}, {"G", "dense"},
                       {"slack_out", true}, {"threads", threads}, {"per_s", per_s}, {"flops", flops},
                       {"gflops", per_s * flops * 1e-9}, {"peak_share", per_s * flops * 1e-9 / (peak1 * threads)}});
        }
      }
    }
  }
  // The envs' case (SafeEnv): only a, lambda and status are needed, so the
  // slack outputs are skipped; dense G as above, and the arm's diagonal
  // G = diag(vmax) without drift.
  for (int diag = 0; diag < 2; ++diag) {
    for (int threads : threads_list) {
      ProjectorModel mod = default_projector_model(7, 7, 34, 0);
      if (diag) {
        mod.g_form = GForm::Diagonal;
        mod.has_drift = false;
      }
      ProjectorBatch B(mod, 16384);
      fill(mod, B, 2);
      set_num_threads(threads);
      const double t = bench::best_seconds_per_call([&] { project_batch(mod, B, {.store_slack = false}); }, 5, 0.1);
      const double per_s = 16384 / t;
      const double flops = flops_per_projection(7, 7, 34, !diag, !diag);  // no u_s
      bench::emit({{"bench", "projector"}, {"N", 16384}, {"k", 34}, {"m", 7}, {"n", 7},
                   {"G", diag ? "diagonal" : "dense"}, {"slack_out", false}, {"threads", threads},
                   {"per_s", per_s}, {"flops", flops}, {"gflops", per_s * flops * 1e-9},
                   {"peak_share", per_s * flops * 1e-9 / (peak1 * threads)}});
    }
  }
  // The smooth (Procrustes) basis and equality rows, k = 34, m = 7, N = 16384,
  // dense G, all outputs: the smooth basis runs in the lane kernel (Jacobi per
  // lane), equality rows take the general per-env path.
  for (int variant = 0; variant < 2; ++variant) {
    ProjectorModel mod = default_projector_model(7, 7, 34, 0);
    if (variant == 0) mod.basis = BasisType::Smooth;
    else mod.equality[0] = mod.equality[1] = 1;
    ProjectorBatch B(mod, 16384);
    fill(mod, B, 3);
    for (int threads : threads_list) {
      set_num_threads(threads);
      const double t = bench::best_seconds_per_call([&] { project_batch(mod, B); }, 3, 0.1);
      bench::emit({{"bench", "projector"}, {"N", 16384}, {"k", 34}, {"m", 7}, {"n", 7}, {"G", "dense"},
                   {"slack_out", true}, {"threads", threads},
                   {"variant", variant == 0 ? "smooth_basis" : "equality_rows_2"}, {"per_s", 16384 / t}});
    }
  }
  return 0;
}
