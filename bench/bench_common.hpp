// Shared helpers for the bench_* programs: timing, CPU name, JSON lines.
#pragma once
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom::bench {

inline double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Runs fn repeatedly; returns the best (minimum) seconds per call over
// `repeats` rounds of at least `min_round_s` each. Minimum, not mean: the
// machine is shared and noise only ever adds time.
inline double best_seconds_per_call(const std::function<void()>& fn, int repeats = 5, double min_round_s = 0.1) {
  fn();  // warm-up: first-touch of scratch, thread pool start
  double best = 1e300;
  for (int r = 0; r < repeats; ++r) {
    long calls = 0;
    const double t0 = now_s();
    double t1 = t0;
    do {
      fn();
      ++calls;
      t1 = now_s();
    } while (t1 - t0 < min_round_s);
    best = std::min(best, (t1 - t0) / static_cast<double>(calls));
  }
  return best;
}

inline std::string cpu_name() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto pos = line.find(':');
      return pos == std::string::npos ? line : line.substr(pos + 2);
    }
  }
  return "unknown";
}

inline void emit(const nlohmann::json& j) {
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
}

// Measured float64 multiply-add peak of one core: 24 independent vector
// accumulators (enough to cover FMA latency x throughput), written with GCC
// vector types of 8 doubles so the build's -march decides the instructions.
// Returns GFLOP/s (2 flops per multiply-add).
inline double measure_f64_peak_gflops_one_core() {
  typedef double V8 __attribute__((vector_size(64)));
  constexpr int kAcc = 24;
  V8 acc[kAcc];
  for (int a = 0; a < kAcc; ++a) acc[a] = V8{} + (1.0 + 1e-3 * a);
  const V8 x = V8{} + 0.999999, y = V8{} + 1e-7;
  const long iters = 2'000'000;
  auto run = [&] {
    for (long it = 0; it < iters; ++it) {
#pragma GCC unroll 24
      for (int a = 0; a < kAcc; ++a) acc[a] = acc[a] * x + y;
    }
  };
  const double t = best_seconds_per_call(run, 3, 0.05);
  double sink = 0;
  for (int a = 0; a < kAcc; ++a) sink += acc[a][0];
  if (sink == 42.0) std::printf("#\n");  // keep the loop alive
  return 2.0 * kAcc * 8 * iters / t * 1e-9;
}

}  // namespace atacom::bench
