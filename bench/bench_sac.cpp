// bench_sac: SAC gradient updates/s, PPO update samples/s, actor actions/s, Adam
// parameters/s, the machine's single-precision GEMM rate and its FMA peak, as
// JSON lines.
//
//   build/bench/bench_sac [--quick]
//
// Every figure is the best of `repeats` timed windows after a warm-up (noisy
// shared machines only ever slow a window down). sac_update includes replay
// sampling; flops counts every GEMM of one update (forward and backward), as
// the tape executes them. sac_update_cpu gives updates per second of process
// CPU time, which other jobs on a shared machine do not distort.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <tbb/parallel_for.h>

#include "atacom/parallel.hpp"
#include "kernels/eigen_exact_gemm.hpp"
#include "train/adam.hpp"
#include "train/ppo.hpp"
#include "train/replay_buffer.hpp"
#include "train/sac.hpp"
#include "bench_common.hpp"

using namespace atacom;
using Clock = std::chrono::steady_clock;

namespace {

int repeats = 5;
double window_s = 1.0;

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Calls fn() in windows of ~window_s; returns the best calls per second.
template <class Fn>
double best_rate(Fn&& fn) {
  for (int i = 0; i < 3; ++i) fn();  // warm-up: arenas, caches, TBB workers
  double best = 0;
  for (int r = 0; r < repeats; ++r) {
    int64_t calls = 0;
    const auto t0 = Clock::now();
    double el = 0;
    do {
      fn();
      ++calls;
      el = std::chrono::duration<double>(Clock::now() - t0).count();
    } while (el < window_s);
    best = std::max(best, double(calls) / el);
  }
  return best;
}

void bench_sac_update(int B, int threads) {
  set_num_threads(threads);
  const int D = 20, A = 7;
  SacConfig cfg = default_sac_config();
  cfg.batch_size = B;
  Sac sac(D, A, cfg, 1);
  ReplayBuffer rb(20000, D, A);
  Rng r(2, 0);
  std::vector<float> o(D), no(D), rew(1), cost(1, 0.0f);
  std::vector<double> a(A);
  for (int i = 0; i < 20000; ++i) {
    for (auto& v : o) v = float(r.uniform(-1, 1));
    for (auto& v : no) v = float(r.uniform(-1, 1));
    for (auto& v : a) v = r.uniform(-1, 1);
    rew[0] = float(r.uniform(-1, 0));
    const uint8_t term = 0, trunc = 0;
    rb.add(1, o.data(), a.data(), rew.data(), cost.data(), no.data(), &term, &trunc);
  }
  ReplayBatch batch;
  batch.resize(B, D, A);
  Rng sample_rng(3, 0);
  auto update = [&]() {
    rb.sample(sample_rng, batch);
    sac.update(batch, true);
  };
  update();
  const double f0 = sac.gemm_flops();
  update();
  const double flops = sac.gemm_flops() - f0;
  const double per_s = best_rate(update);
  bench::emit({{"bench", "sac_update"}, {"obs", D}, {"act", A}, {"hidden", {256, 256}}, {"batch", B},
               {"threads", threads}, {"per_s", per_s}, {"flops", flops}, {"gflops", flops * per_s * 1e-9},
               {"cpu", bench::cpu_name()}});
  // Updates per second of process CPU time (all threads): robust to other
  // jobs on the machine, and shows the parallel overhead (spinning workers,
  // task spawns) as a drop from the 1-thread figure.
  const double c0 = cpu_seconds();
  const auto w0 = Clock::now();
  int64_t n = 0;
  while (std::chrono::duration<double>(Clock::now() - w0).count() < window_s) {
    update();
    ++n;
  }
  const double cpu = cpu_seconds() - c0;
  // per_s: updates per second of process CPU time.
  bench::emit({{"bench", "sac_update_cpu"}, {"batch", B}, {"threads", threads}, {"per_s", double(n) / cpu},
               {"cpus_used", cpu / std::chrono::duration<double>(Clock::now() - w0).count()}});
}

void bench_actor_act(int N, int threads) {
  set_num_threads(threads);
  const int D = 20, A = 7;
  Sac sac(D, A, default_sac_config(), 1);
  std::vector<float> obs(size_t(N) * D);
  Rng r(4, 0);
  for (auto& v : obs) v = float(r.uniform(-1, 1));
  std::vector<Rng> rngs;
  for (int i = 0; i < N; ++i) rngs.emplace_back(5, uint64_t(i));
  std::vector<double> act(size_t(N) * A);
  const double calls = best_rate([&]() { sac.act(obs.data(), N, false, rngs.data(), act.data()); });
  // obs 20, act 7, hidden 256-256 like sac_update; stochastic actions
  bench::emit({{"bench", "actor_act"}, {"N", N}, {"threads", threads}, {"per_s", calls * N}});
}

// Adam's fused step (moments, parameters, gradient reset, Polyak target)
// over n parameters, the size of one SAC critic pair; per_s counts
// parameters. The gradient is refilled each call with typical magnitudes,
// none subnormal, so the flush never takes a microcode assist.
void bench_adam_step(int64_t n, int threads) {
  set_num_threads(threads);
  Adam<float> opt(size_t(n), default_adam_config());
  const size_t len = size_t(n);
  std::vector<float> p(len), g(len), grad(len), target(len);
  Rng r(6, 0);
  for (int64_t i = 0; i < n; ++i) {
    p[size_t(i)] = target[size_t(i)] = float(r.uniform(-1, 1));
    grad[size_t(i)] = float(r.uniform(-1e-2, 1e-2));
  }
  const double calls = best_rate([&]() {
    std::copy(grad.begin(), grad.end(), g.begin());
    opt.step_fused(p.data(), g.data(), 3e-4, target.data(), 1e-3);
  });
  bench::emit({{"bench", "adam_step"}, {"N", n}, {"threads", threads}, {"per_s", calls * double(n)}});
}

// Eigen's float GEMM C = A B, one independent product per thread (Eigen
// itself runs single-threaded here), aggregate rate.
void bench_gemm_peak(int m, int k, int n, int threads) {
  set_num_threads(threads);
  using M = RowMat<float>;
  std::vector<M> As, Bs, Cs;
  for (int t = 0; t < threads; ++t) {
    As.push_back(M::Random(m, k));
    Bs.push_back(M::Random(k, n));
    Cs.push_back(M::Zero(m, n));
  }
  const int inner = std::max(1, int(2e7 / (2.0 * m * k * n)));
  auto run = [&]() {
    tbb::parallel_for(0, threads, [&](int t) {
      for (int i = 0; i < inner; ++i) Cs[size_t(t)].noalias() = As[size_t(t)] * Bs[size_t(t)];
    });
  };
  const double per_s = best_rate(run);
  // per_s: GEMM calls per second over all threads; gflops: per thread (each
  // thread runs its own product), comparable with one core's peak.
  bench::emit({{"bench", "gemm_peak"}, {"m", m}, {"k", k}, {"n", n}, {"threads", threads}, {"per_s", per_s * inner * threads},
               {"gflops", per_s * inner * 2.0 * m * k * n * 1e-9}});
}

// One GEMM as the tape runs it, in 128-column tiles on one thread, through
// the Eigen-exact kernel and through the Eigen expression it replaces (same
// bits): forward Y += X W (m x k times k x n), dW += X^T dY (k rows of X
// and dY, n columns of dW), dX += dY W^T (W is n x k). `gflops` per call.
// `cache`: "warm" repeats the call with its operands in cache; "cold" sweeps
// 8 MB through the caches before each call (not timed), as the update's
// other work does; "cold_a", "cold_b", "cold_c" read every operand but that
// one back in after the sweep, to show which one costs.
void bench_gemm_tile(const char* form, int m, int k, int n) {
  set_num_threads(1);
  using M = RowMat<float>;
  const bool tn = !std::strcmp(form, "dw"), nt = !std::strcmp(form, "dx");
  const M a = tn ? M::Random(k, m) : M::Random(m, k), b = nt ? M::Random(n, k) : M::Random(k, n);
  M c = M::Zero(m, n);
  const int64_t lda = a.cols(), ldb = b.cols();
  std::vector<float> sweep(size_t(8) << 18, 1.0f);  // 8 MB: more than L2, as the update's working set
  float sink = 0;
  auto touch = [&sink](const float* x, size_t len) {  // one read per cache line
    for (size_t i = 0; i < len; i += 16) sink += x[i];
  };
  for (const bool exact : {true, false}) {
    auto call = [&]() {
      for (int c0 = 0; c0 < n; c0 += 128) {
        const int nc = std::min(128, n - c0);
        float* ct = c.data() + c0;
        MatMap<float> C(ct, m, nc, Eigen::OuterStride<>(n));
        if (tn) {
          if (!exact || !eigen_exact_gemm(m, nc, k, a.data(), 1, lda, b.data() + c0, ldb, 1, ct, n, nullptr, false))
            C.noalias() += CMatMap<float>(a.data(), k, m, Eigen::OuterStride<>(lda)).transpose() *
                           CMatMap<float>(b.data() + c0, k, nc, Eigen::OuterStride<>(ldb));
        } else if (nt) {
          const float* bt = b.data() + int64_t(c0) * ldb;
          if (!exact || !eigen_exact_gemm(m, nc, k, a.data(), lda, 1, bt, 1, ldb, ct, n, nullptr, false))
            C.noalias() += CMatMap<float>(a.data(), m, k, Eigen::OuterStride<>(lda)) *
                           CMatMap<float>(bt, nc, k, Eigen::OuterStride<>(ldb)).transpose();
        } else {
          if (!exact || !eigen_exact_gemm(m, nc, k, a.data(), lda, 1, b.data() + c0, ldb, 1, ct, n, nullptr, false))
            C.noalias() += CMatMap<float>(a.data(), m, k, Eigen::OuterStride<>(lda)) *
                           CMatMap<float>(b.data() + c0, k, nc, Eigen::OuterStride<>(ldb));
        }
      }
    };
    // cold: the operand left cold after the sweep ('*' all of them); warm: no sweep.
    struct Cache { const char* name; char cold; };
    for (const Cache cache : {Cache{"warm", 0}, Cache{"cold", '*'}, Cache{"cold_a", 'a'}, Cache{"cold_b", 'b'},
                              Cache{"cold_c", 'c'}}) {
      double per_s = 0;
      if (!cache.cold) {
        per_s = best_rate(call);
      } else {
        const int calls = repeats * 200;
        double timed = 0;
        for (int i = 0; i < calls; ++i) {
          for (size_t j = 0; j < sweep.size(); j += 16) sweep[j] += 1.0f;
          if (cache.cold != '*') {
            if (cache.cold != 'a') touch(a.data(), size_t(a.size()));
            if (cache.cold != 'b') touch(b.data(), size_t(b.size()));
            if (cache.cold != 'c') touch(c.data(), size_t(c.size()));
          }
          const auto t0 = Clock::now();
          call();
          timed += std::chrono::duration<double>(Clock::now() - t0).count();
        }
        per_s = calls / timed;
      }
      bench::emit({{"bench", "gemm_tile"}, {"form", form}, {"m", m}, {"k", k}, {"n", n}, {"threads", 1},
                   {"kernel", exact ? "exact" : "eigen"}, {"cache", cache.name}, {"per_s", per_s},
                   {"gflops", per_s * 2.0 * m * k * n * 1e-9}});
    }
  }
  if (sink == 12345.0f) std::fprintf(stderr, " ");  // keeps the reads
}

// The cores' float32 FMA peak: 12 independent multiply-add chains per thread
// on Eigen's widest float packet, 2 FLOP per lane. `gflops` is per thread, so
// it compares with gemm_peak's and with sac_update's per-core rate.
double bench_fma_peak(int threads, bool print = true) {
  set_num_threads(threads);
  namespace ei = Eigen::internal;
  using P = ei::packet_traits<float>::type;
  constexpr int kLanes = ei::packet_traits<float>::size, kChains = 12;
  constexpr long kSteps = 1 << 20;
  std::vector<float> sink(size_t(threads), 0.0f);
  auto run = [&]() {
    tbb::parallel_for(0, threads, [&](int t) {
      P acc[kChains];
      for (int c = 0; c < kChains; ++c) acc[c] = ei::pset1<P>(1.0f + 1e-7f * float(c + t));
      const P mul = ei::pset1<P>(0.9999999f), add = ei::pset1<P>(1e-7f);
      for (long i = 0; i < kSteps; ++i)
        for (int c = 0; c < kChains; ++c) acc[c] = ei::pmadd(acc[c], mul, add);
      float s = 0;
      for (int c = 0; c < kChains; ++c) s += ei::predux(acc[c]);
      sink[size_t(t)] = s;  // keeps the chains live
    });
  };
  const double per_s = best_rate(run);
  const double flops_per_thread = double(kSteps) * kChains * kLanes * 2.0;
  if (print)
    bench::emit({{"bench", "fma_peak"}, {"threads", threads}, {"lanes", kLanes},
                 {"per_s", per_s * flops_per_thread * threads}, {"gflops", per_s * flops_per_thread * 1e-9}});
  return per_s * flops_per_thread * 1e-9;
}

// One PPO update (train/ppo.hpp) over a full rollout of N envs x T steps
// with random data (obs 16, act 7: TableEnv's shapes): the value pass, GAE,
// and `epochs` passes of minibatches (forward, backward and Adam of actor and
// critic). per_s: samples through a gradient step per second (N T epochs /
// seconds per update); gflops: every GEMM of the update as the tapes run
// them; share_of_fma_peak: gflops over fma_peak's per-thread rate x threads,
// measured in this process just before.
void bench_ppo_update(int N, int T, const std::vector<int>& hidden, Activation act, int minibatch, int threads,
                      double fma_gflops) {
  set_num_threads(threads);
  const int D = 16, A = 7;
  PpoConfig cfg = default_ppo_config();
  cfg.actor.hidden = cfg.critic.hidden = hidden;
  cfg.actor.activation = cfg.critic.activation = act;
  cfg.rollout_steps = T;
  cfg.minibatch_size = minibatch;
  Ppo ppo(D, A, cfg, 1);
  PpoRollout roll;
  roll.resize(T, N, D, A);
  Rng r(7, 0);
  for (auto& v : roll.obs) v = float(r.uniform(-1, 1));
  for (auto& v : roll.sample) v = float(r.uniform(-1.5, 1.5));
  for (auto& v : roll.logp) v = float(r.uniform(-12, -8));
  for (auto& v : roll.reward) v = float(r.uniform(-1, 0));
  for (auto& v : roll.last_obs) v = float(r.uniform(-1, 1));
  roll.steps = T;
  auto update = [&]() {
    // lr 0: every call does the same work on the same parameters
    ppo.update(roll, 0.0, 0.0);
  };
  update();
  const double f0 = ppo.gemm_flops();
  update();
  const double flops = ppo.gemm_flops() - f0;
  const double calls = best_rate(update);
  const double gflops = flops * calls * 1e-9;
  bench::emit({{"bench", "ppo_update"}, {"obs", D}, {"act", A}, {"hidden", hidden},
               {"activation", activation_name(act)}, {"N", N}, {"T", T},
               {"epochs", cfg.epochs}, {"minibatch", minibatch}, {"threads", threads},
               {"per_s", calls * double(N) * T * cfg.epochs}, {"updates_per_s", calls}, {"flops", flops},
               {"gflops", gflops}, {"share_of_fma_peak", gflops / (fma_gflops * threads)}, {"cpu", bench::cpu_name()}});
}

}  // namespace

int main(int argc, char** argv) {
  // --only, --batch and --threads narrow the grid (profiling one case).
  std::string only;
  int batch_only = 0, threads_only = 0;
  auto usage = []() {
    std::fprintf(stderr, "usage: bench_sac [--quick] [--only sac_update|ppo_update|actor_act|adam_step|gemm_peak|gemm_tile|fma_peak]\n"
                         "                 [--batch B] [--threads T] [--repeats R] [--window SECONDS]\n");
    return 2;
  };
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--quick")) {
      repeats = 2;
      window_s = 0.3;
    } else if (!std::strcmp(argv[i], "--only") && has_value) {
      only = argv[++i];
      if (only != "sac_update" && only != "ppo_update" && only != "actor_act" && only != "adam_step" && only != "gemm_peak" &&
          only != "gemm_tile" && only != "fma_peak")
        return usage();
    } else if (!std::strcmp(argv[i], "--batch") && has_value) {
      batch_only = bench::flag_value<int>("--batch", argv[++i], range::closed(1, 65536));
    } else if (!std::strcmp(argv[i], "--threads") && has_value) {
      threads_only = bench::flag_value<int>("--threads", argv[++i], range::closed(1, 256));
    } else if (!std::strcmp(argv[i], "--repeats") && has_value) {
      repeats = bench::flag_value<int>("--repeats", argv[++i], range::closed(1, 10000));
    } else if (!std::strcmp(argv[i], "--window") && has_value) {
      window_s = bench::flag_value<double>("--window", argv[++i], range::open_closed(0.0, 600.0));
    } else {
      return usage();
    }
  }
  std::vector<int> thread_list = {1, 2};
  if (threads_only) thread_list = {threads_only};
  std::vector<int> batch_list = {64, 256};
  if (batch_only) batch_list = {batch_only};
  const auto want = [&](const char* name) { return only.empty() || only == name; };
  if (want("sac_update"))
    for (int threads : thread_list)
      for (int B : batch_list) bench_sac_update(B, threads);
  if (want("ppo_update"))
    for (int threads : thread_list) {
      const double peak = bench_fma_peak(threads, false);
      // PPO's defaults on 128 envs (the preset cells' N: 64-64 ReLU, T 16,
      // minibatches of 512), the same at 256-256, and large rollouts and
      // minibatches (1024 envs x T 32, 4096) with ReLU and tanh.
      struct Case { int N, T; std::vector<int> hidden; Activation act; int minibatch; };
      const std::vector<Case> cases = {{128, 16, {64, 64}, Activation::Relu, 512},
                                        {128, 16, {256, 256}, Activation::Relu, 512},
                                        {1024, 32, {64, 64}, Activation::Relu, 4096},
                                        {1024, 32, {64, 64}, Activation::Tanh, 4096},
                                        {1024, 32, {256, 256}, Activation::Relu, 4096}};
      for (const Case& c : cases)
        bench_ppo_update(c.N, c.T, c.hidden, c.act, batch_only ? batch_only : c.minibatch, threads, peak);
    }
  if (want("actor_act"))
    for (int threads : thread_list)
      for (int N : {1, 1024, 16384}) bench_actor_act(N, threads);
  if (want("adam_step"))
    for (int threads : thread_list) bench_adam_step(150000, threads);
  if (want("gemm_peak"))
    for (int threads : thread_list) {
      bench_gemm_peak(64, 256, 256, threads);
      bench_gemm_peak(256, 256, 256, threads);
      bench_gemm_peak(64, 27, 256, threads);
      bench_gemm_peak(1024, 1024, 1024, threads);
    }
  if (want("gemm_tile")) {
    // The update's 256x256 hidden layer at batch 64: forward, dW, dX.
    bench_gemm_tile("forward", 64, 256, 256);
    bench_gemm_tile("dw", 256, 64, 256);
    bench_gemm_tile("dx", 64, 256, 256);
  }
  if (want("fma_peak"))
    for (int threads : thread_list) bench_fma_peak(threads);
  return 0;
}
