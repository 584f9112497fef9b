// Benchmark of the human kernels per env step: motion playback (Catmull-Rom
// sample of 38 numbers), capsule FK with velocities (16 capsules on a
// 20-joint chain), 9 PoI rows against the 16 capsules, and the exact contact
// check of the arm's 9 link capsules and 9 PoI spheres (random arm
// configurations, the human replaying the train split). One JSON line per kernel and setting:
//   {"bench": "human_<kernel>", "N": .., "threads": .., "per_s": env-steps/s, ...}
#include <cstdio>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "bench/bench_common.hpp"
#include "src/core/limits.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_rows.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "envs/arm/tiago_model.hpp"
#include "kernels/human_kernels.hpp"

using namespace atacom;

namespace {
// CPU seconds of the calling thread: on a shared machine it leaves out the
// time the thread waited for a core (one-thread lines only).
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<int> Ns = {256, 4096};
  if (argc > 1) Ns = {bench::flag_value<int>("N", argv[1], range::closed(1, limits::kMaxEnvs))};
  const HumanModel m = load_human_model();
  const HumanMotionLibrary lib = load_default_human_motion();
  const HumanReplayConfig replay;
  const TiagoArmModel arm = load_tiago_arm_model(0.3);
  const int P = 9, nq = 7;
  const int items = static_cast<int>(arm.capsules.size()) + kArmPoi;
  const HumanRowsConst rows = make_human_rows(std::vector<double>(P, 0.12), nq, 0.02);
  const double peak = bench::measure_f64_peak_gflops_one_core();
  for (int N : Ns) {
    Rng rng(1, 0);
    HumanBatch B(N);
    std::vector<double> t(static_cast<size_t>(N));
    for (double& x : t) x = human_episode_start(lib, replay, 500, rng);
    // The arm in random configurations (the human stands around the table
    // in front of it): PoIs, their Jacobians, link capsules and PoI spheres.
    std::vector<double> poi(static_cast<size_t>(N) * P * 3), J(static_cast<size_t>(N) * P * 3 * nq);
    std::vector<double> it(static_cast<size_t>(N) * items * 6), radii;
    for (const ArmCapsule& cap : arm.capsules) radii.push_back(cap.radius);
    for (const ArmPoi& p : arm.poi) radii.push_back(p.radius);
    for (int e = 0; e < N; ++e) {
      ArmQ q;
      for (int j = 0; j < kArmJoints; ++j) q(j) = rng.uniform(arm.lower[static_cast<size_t>(j)], arm.upper[static_cast<size_t>(j)]);
      const ArmFkResult fk = arm_fk_reference(arm, q);
      for (int i = 0; i < P; ++i)
        for (int r = 0; r < 3; ++r) {
          poi[(static_cast<size_t>(e) * P + i) * 3 + r] = fk.poi[static_cast<size_t>(i)](r);
          for (int j = 0; j < nq; ++j) J[((static_cast<size_t>(e) * P + i) * 3 + r) * nq + j] = fk.J_poi[static_cast<size_t>(i)](r, j);
        }
      double* o = &it[static_cast<size_t>(e) * items * 6];
      for (const ArmCapsule& cap : arm.capsules) {
        const Eigen::Vector3d a = fk.frame[static_cast<size_t>(cap.frame)].apply(cap.a), b = fk.frame[static_cast<size_t>(cap.frame)].apply(cap.b);
        for (int r = 0; r < 3; ++r) {
          o[r] = a(r);
          o[3 + r] = b(r);
        }
        o += 6;
      }
      for (int i = 0; i < kArmPoi; ++i, o += 6)
        for (int r = 0; r < 3; ++r) o[r] = o[3 + r] = fk.poi[static_cast<size_t>(i)](r);
    }
    std::vector<double> c(static_cast<size_t>(N) * P), Jq(static_cast<size_t>(N) * P * nq), dcdt(c), dex(c), dmin(N);
    std::vector<uint8_t> contact(N);
    const int block = 256;
    struct Kernel {
      const char* name;
      std::function<void(int64_t, int64_t)> run;
      double flops;  // per env, counted by hand (docs/human.md)
    };
    const std::vector<Kernel> kernels = {
        {"human_motion", [&](int64_t lo, int64_t hi) { human_motion_range(lib, replay, 1.0 / 30, t.data(), B, int(lo), int(hi)); }, 0},
        {"human_capsules", [&](int64_t lo, int64_t hi) { human_capsules_range(m.fk, B, int(lo), int(hi)); }, 4600},
        {"human_rows",
         [&](int64_t lo, int64_t hi) {
           human_rows_range(rows, m.fk, B, poi.data(), J.data(), c.data(), Jq.data(), dcdt.data(), dex.data(), int(lo), int(hi));
         },
         9.0 * 16 * 73 + 9 * 7 * 6},
        {"human_contact",
         [&](int64_t lo, int64_t hi) {
           human_contact_range(B, m.fk, it.data(), radii.data(), items, contact.data(), nullptr, int(lo), int(hi));
         },
         0},
    };
    for (int threads : {1, 2}) {
      set_num_threads(threads);
      for (const Kernel& k : kernels) {
        const double s = bench::best_seconds_per_call([&] { parallel_blocks(N, block, k.run); }, 5, 0.1);
        nlohmann::json line = {{"bench", k.name}, {"N", N}, {"threads", threads}, {"per_s", N / s},
                               {"ns_per_env", s / N * 1e9}, {"cpu", bench::cpu_name()}};
        if (threads == 1) {  // the calling thread runs every block
          double best = 1e300;
          for (int r = 0; r < 5; ++r) {
            const double c0 = thread_cpu_s();
            for (int rep = 0; rep < 20; ++rep) k.run(0, N);
            best = std::min(best, (thread_cpu_s() - c0) / 20);
          }
          line["cpu_ns_per_env"] = best / N * 1e9;
        }
        if (k.flops > 0) {
          line["gflops"] = k.flops * N / s * 1e-9;
          line["peak_share"] = k.flops * N / s * 1e-9 / (peak * threads);
        }
        bench::emit(line);
      }
    }
  }
  return 0;
}
