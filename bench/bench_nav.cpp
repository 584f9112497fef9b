// NavEnv throughput: env steps per second with and without ATACOM, and the
// share of step time spent inside Box2D.
//
// One JSON line per configuration: N in {1, 256, 4096}, threads in {1, 2},
// atacom in {false, true}, envs built by the registry (with ATACOM: SafeEnv
// around NavEnv, as training uses it). Random alpha in [-1, 1]^2 (16
// precomputed batches, cycled). Throughput is the best of 5 rounds of
// at least 0.3 s; the Box2D share comes from a separate round with the env's
// profiling hooks on (they add two clock reads per block and section).
//
//   steps_per_s        env steps per second (N x step calls / wall seconds)
//   box2d_share        Box2D thread-seconds / (wall seconds x busy threads)
//   box2d_us_per_step  Box2D thread-microseconds per env step
//
// Usage: bench_nav [--quick]
#include <algorithm>
#include <cstring>
#include <vector>

#include "atacom/env_registry.hpp"
#include "atacom/nav_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "bench_common.hpp"

using namespace atacom;

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const std::string cpu = bench::cpu_name();
  const NavConfig cfg = default_nav_config();
  const int Ns[] = {1, 256, 4096};
  const int threads_list[] = {1, 2};
  const int batches = 16;
  for (int N : Ns) {
    if (quick && N != 4096) continue;
    std::vector<std::vector<double>> alpha(batches, std::vector<double>(2 * static_cast<size_t>(N)));
    Rng rng(7, 0);
    for (auto& b : alpha)
      for (auto& v : b) v = rng.uniform(-1.0, 1.0);
    for (bool atacom : {false, true}) {
      for (int threads : threads_list) {
        set_num_threads(threads);
        EnvRequest req;
        req.name = "nav";
        req.num_envs = N;
        req.atacom = atacom;
        std::unique_ptr<BatchEnv> env = make_env(req);
        env->seed(1);
        int call = 0;
        auto step = [&] { env->step(alpha[call++ % batches].data()); };
        const double t = bench::best_seconds_per_call(step, quick ? 3 : 5, 0.3);
        // Profiled round for the Box2D share.
        env->set_profiling(true);
        long calls = 0;
        const double t0 = bench::now_s();
        double t1 = t0;
        do {
          step();
          ++calls;
          t1 = bench::now_s();
        } while (t1 - t0 < 0.3);
        const std::vector<double> sec = env->profile_seconds();
        env->set_profiling(false);
        const int blocks = (N + cfg.block - 1) / cfg.block;
        const int busy = std::min(threads, blocks);
        const double steps = static_cast<double>(calls) * N;
        bench::emit({{"bench", "env"},
                     {"env", "nav"},
                     {"N", N},
                     {"threads", threads},
                     {"atacom", atacom},
                     {"steps_per_s", N / t},
                     {"box2d_share", sec[0] / ((t1 - t0) * busy)},
                     {"box2d_us_per_step", sec[0] / steps * 1e6},
                     {"cpu", cpu}});
      }
    }
  }
  return 0;
}
