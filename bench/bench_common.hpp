// Shared helpers for the bench_* programs: timing, CPU name, JSON lines.
#pragma once
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <cstdlib>
#include <string>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <nlohmann/json.hpp>

#include "src/core/value_range.hpp"

namespace atacom::bench {

// Every numeric argument of a bench program goes through the project's one
// flag parser (src/core/value_range.hpp, as every `atacom` flag): the whole
// text, decimal, inside `r`; otherwise the reason on stderr and exit code 2.
template <class T>
T flag_value(const char* flag, const std::string& text, const Range<T>& r) {
  try {
    return parse_flag_value<T>(flag, text, r);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s\n", e.what());
    std::exit(2);
  }
}

// "1,256,4096": each entry through flag_value.
inline std::vector<int> flag_list(const char* flag, const std::string& text, const Range<int>& r) {
  std::vector<int> out;
  size_t pos = 0;
  while (true) {
    const size_t comma = text.find(',', pos);
    out.push_back(flag_value<int>(flag, text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos), r));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

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

// Measured float64 multiply-add peak of one core: 24 independent register
// accumulators (more than FMA latency x ports), 8 doubles each, AVX-512
// intrinsics where the build has them (GCC's vector extensions left the
// accumulators in memory here and measured a third of the real peak).
// Returns GFLOP/s (2 flops per multiply-add).
inline double measure_f64_peak_gflops_one_core() {
  constexpr int kAcc = 24;
  const long iters = 4'000'000;
#if defined(__AVX512F__)
  __m512d state[kAcc];
  for (int a = 0; a < kAcc; ++a) state[a] = _mm512_set1_pd(1.0 + 1e-3 * a);
  auto run = [&] {
    // Local copies: accumulators captured by reference would live in memory.
    __m512d acc[kAcc];
    for (int a = 0; a < kAcc; ++a) acc[a] = state[a];
    const __m512d x = _mm512_set1_pd(0.999999), y = _mm512_set1_pd(1e-7);
    for (long it = 0; it < iters; ++it) {
#pragma GCC unroll 24
      for (int a = 0; a < kAcc; ++a) acc[a] = _mm512_fmadd_pd(acc[a], x, y);
    }
    for (int a = 0; a < kAcc; ++a) state[a] = acc[a];
  };
  const double t = best_seconds_per_call(run, 3, 0.05);
  double sink = 0;
  for (int a = 0; a < kAcc; ++a) sink += _mm512_reduce_add_pd(state[a]);
#else
  typedef double V8 __attribute__((vector_size(64)));
  V8 state[kAcc];
  for (int a = 0; a < kAcc; ++a) state[a] = V8{} + (1.0 + 1e-3 * a);
  auto run = [&] {
    V8 acc[kAcc];
    for (int a = 0; a < kAcc; ++a) acc[a] = state[a];
    const V8 x = V8{} + 0.999999, y = V8{} + 1e-7;
    for (long it = 0; it < iters; ++it) {
#pragma GCC unroll 24
      for (int a = 0; a < kAcc; ++a) acc[a] = acc[a] * x + y;
    }
    for (int a = 0; a < kAcc; ++a) state[a] = acc[a];
  };
  const double t = best_seconds_per_call(run, 3, 0.05);
  double sink = 0;
  for (int a = 0; a < kAcc; ++a) sink += state[a][0];
#endif
  if (sink == 42.0) std::printf("#\n");  // keep the loop alive
  return 2.0 * kAcc * 8 * iters / t * 1e-9;
}

}  // namespace atacom::bench
