// Thread control and block-parallel loops.
//
// Every batched kernel works on an index range [begin, end). parallel_blocks
// cuts [0, N) into fixed-size blocks (independent of the thread count) and
// runs them on TBB workers, so per-env results never depend on threads.
#pragma once
#include <cstdint>
#include <memory>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace atacom {

// Task sizes, one place. Fixed (never derived from the thread count), so
// per-env results never depend on threads; they tune speed only.
constexpr int64_t kEnvBlock = 256;         // envs per task: env steps, projector, safety layers (model + scratch in L2)
constexpr int64_t kSampleBlock = 1024;     // samples per task in light per-sample loops (action sampling)
constexpr int64_t kCheapEnvBlock = 4096;   // envs per task for envs of a few dozen flops a step (pendulum)

// Limit the worker count for the rest of the process (0 = all cores).
void set_num_threads(int threads);
int num_threads();

template <class Fn>
void parallel_blocks(int64_t n, int64_t block, Fn&& fn) {
  if (n <= 0) return;
  if (block <= 0) block = 1;
  const int64_t nblocks = (n + block - 1) / block;
  if (nblocks == 1) { fn(int64_t{0}, n); return; }
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, nblocks, 1),
                    [&](const tbb::blocked_range<int64_t>& r) {
                      for (int64_t b = r.begin(); b != r.end(); ++b) {
                        const int64_t lo = b * block;
                        const int64_t hi = lo + block < n ? lo + block : n;
                        fn(lo, hi);
                      }
                    },
                    tbb::simple_partitioner());
}

}  // namespace atacom
