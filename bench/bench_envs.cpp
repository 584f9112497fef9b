// bench_envs: batched env steps per second for every registered env that has
// a constraint model, with and without ATACOM, over env counts and thread
// counts, plus the time split between the env's profiled sections (e.g.
// kinematics, distances, physics) and the projector.
//
// One JSON line per configuration:
//   {"bench": "env_step", "env": "table", "atacom": true, "N": 4096,
//    "threads": 2, "per_s": ..., "split": {...}, "cpu": "..."}
// per_s counts agent steps (one per env per step() call; no frame skip).
// The policy is uniform random alpha (pre-drawn, cycled), so episodes end
// and autoreset exactly as in training.
//
// --sdf analytic|learned switches the distance fields of the arm envs
// (envs/arm/arm_learned_sdf.hpp; "default": each env's own, learned on hri);
// lines carry "sdf".
//
// ATACOM path: the registry's SafeEnv (constraint model + projection per
// block, then the inner step). split: shares of thread time (wall time x
// threads in use) from the env's profiling hooks, which sum seconds over
// threads; SafeEnv adds "projector"; rest is what no section accounts for.
#include <cstring>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "src/cli/flag_checks.hpp"
#include "src/core/limits.hpp"

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "bench/bench_common.hpp"
#include "envs/arm/arm_learned_sdf.hpp"

using namespace atacom;

namespace {

constexpr int kActionSets = 8;    // distinct pre-drawn alpha matrices, cycled
constexpr int kBlockEnvs = 256;   // envs per parallel task in the envs and SafeEnv

struct Run {
  std::unique_ptr<BatchEnv> env;
  std::vector<std::vector<double>> alpha;
  int next = 0;

  Run(const std::string& name, int N, bool atacom, const std::string& sdf) {
    const nlohmann::json cfg = sdf == "default" ? nlohmann::json::object() : sdf_flag_override(name, sdf);
    env = make_env({name, N, atacom ? SafetyLayer::Atacom : SafetyLayer::None, cfg});
    env->seed(1);
    const int m = env->spec().act_dim;
    Rng rng(2, 0);
    alpha.assign(kActionSets, std::vector<double>(static_cast<size_t>(N) * m));
    for (auto& a : alpha)
      for (double& x : a) x = rng.uniform(-1.0, 1.0);
  }

  void step() {
    env->step(alpha[next].data());
    next = (next + 1) % kActionSets;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_envs: batched env steps per second with and without ATACOM"};
  std::vector<std::string> envs;
  std::string Ns = "1,256,4096", threads_s = "1,2", atacom_s = "both", sdf = "default";
  int repeats = 5;
  double round_s = 0.2;
  app.add_option("--env", envs, "env names (default: every registered env with a constraint model)");
  app.add_option("--N", Ns, "comma-separated env counts");
  app.add_option("--threads", threads_s, "comma-separated thread counts");
  app.add_option("--atacom", atacom_s, "on, off or both")->check(CLI::IsMember({"on", "off", "both"}));
  cli::add_number_flag(app, "--repeats", repeats, range::closed(1, 10000), "timing rounds (best is kept)");
  cli::add_number_flag(app, "--round-seconds", round_s, range::open_closed(0.0, 600.0), "minimum seconds per timing round");
  app.add_option("--sdf", sdf, "distance fields: default (each env's own), analytic or learned")
      ->check(CLI::IsMember({"default", "analytic", "learned"}));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // a usage error exits 2, as every atacom command
  }
  if (envs.empty())
    for (const EnvEntry& e : env_entries())
      if (e.has_constraints) envs.push_back(e.name);
  std::vector<bool> modes;
  if (atacom_s != "on") modes.push_back(false);
  if (atacom_s != "off") modes.push_back(true);
  const std::string cpu = bench::cpu_name();
  try {
    for (const std::string& name : envs)
      for (bool atacom : modes)
        for (int threads : bench::flag_list("--threads", threads_s, range::closed(1, limits::kMaxThreads)))
          for (int N : bench::flag_list("--N", Ns, range::closed(1, limits::kMaxEnvs))) {
            set_num_threads(threads);
            Run run(name, N, atacom, sdf);
            const double sec = bench::best_seconds_per_call([&] { run.step(); }, repeats, round_s);
            // Time split from a separate profiled pass (profiling adds clock reads).
            const std::vector<std::string> sections = run.env->profile_sections();
            run.env->set_profiling(true);
            const int split_steps = std::max(20, static_cast<int>(2e5 / N));
            const double t0 = bench::now_s();
            for (int s = 0; s < split_steps; ++s) run.step();
            const double wall = bench::now_s() - t0;
            const std::vector<double> secs = run.env->profile_seconds();
            run.env->set_profiling(false);
            double accounted = 0.0;
            for (size_t i = 0; i < sections.size() && i < secs.size(); ++i)
              if (sections[i] != "rest") accounted += secs[i];
            // Threads in use: envs with smaller blocks than kBlockEnvs (nav
            // steps 64 worlds per task) keep more threads busy than N / 256
            // suggests; the sections' own thread-seconds then tell.
            int used_threads = std::min(threads, std::max(1, (N + kBlockEnvs - 1) / kBlockEnvs));
            if (accounted > wall * used_threads) used_threads = threads;
            const double thread_time = wall * used_threads;
            nlohmann::json split = nlohmann::json::object();
            for (size_t i = 0; i < sections.size() && i < secs.size(); ++i)
              if (sections[i] != "rest") split[sections[i]] = secs[i] / thread_time;
            split["rest"] = std::max(0.0, 1.0 - accounted / thread_time);
            bench::emit({{"bench", "env_step"},
                         {"env", name},
                         {"atacom", atacom},
                         {"sdf", sdf},
                         {"N", N},
                         {"threads", threads},
                         {"per_s", N / sec},
                         {"us_per_env_step", sec / N * 1e6},
                         {"split", split},
                         {"cpu", cpu}});
          }
  } catch (const std::exception& e) {
    std::cerr << "bench_envs: error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
