#include "train/rollout.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "atacom/env_registry.hpp"
#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"

namespace atacom {

nlohmann::json run_rollout(const RolloutConfig& cfg) {
  if (cfg.policy != "random" && cfg.policy != "zero")
    throw std::invalid_argument("unknown policy '" + cfg.policy + "' (random, zero)");
  if (cfg.envs < 1) throw std::invalid_argument("--envs must be >= 1");
  if (cfg.steps < 1) throw std::invalid_argument("--steps must be >= 1");
  auto env = make_env(EnvRequest{cfg.env, cfg.envs, cfg.atacom ? SafetyLayer::Atacom : SafetyLayer::None, cfg.env_config});
  const EnvSpec& spec = env->spec();
  const int N = cfg.envs, m = spec.act_dim, k = spec.num_constraints;
  env->seed(cfg.seed);

  // Per-env action streams, distinct from the env's own streams.
  std::vector<Rng> rng;
  rng.reserve(N);
  for (int i = 0; i < N; ++i) rng.emplace_back(cfg.seed ^ 0xA5A5A5A5ull, static_cast<uint64_t>(i) + (1ull << 40));
  std::vector<double> actions(size_t(N) * m, 0.0);

  const size_t ni = spec.info_names.size();
  std::vector<int> collision_cols;
  for (size_t c = 0; c < ni; ++c) {
    const std::string& name = spec.info_names[c];
    if (name.size() >= 9 && name.compare(name.size() - 9, 9, "collision") == 0) collision_cols.push_back(int(c));
  }
  std::vector<double> collision_sums(collision_cols.size(), 0.0);
  long episodes = 0, terminations = 0, violations = 0, nonfinite = 0;
  double max_c = -INFINITY;
  const long rounds = (cfg.steps + N - 1) / N;
  long done_steps = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long r = 0; r < rounds; ++r) {
    const int active = static_cast<int>(std::min<long>(N, cfg.steps - done_steps));
    if (cfg.policy == "random")
      for (int i = 0; i < N; ++i)
        for (int j = 0; j < m; ++j) actions[size_t(i) * m + j] = rng[i].uniform(-1.0, 1.0);
    env->step(actions.data());
    const EnvBuffers& b = env->buffers();
    // The last round may overshoot the requested total: count only `active` envs.
    for (int i = 0; i < active; ++i) {
      episodes += b.done(i);
      terminations += b.terminated[i] != 0;
      bool violated = false;
      for (int row = 0; row < k; ++row) {
        const double c = b.constraints[size_t(i) * k + row];
        if (!std::isfinite(c)) {
          ++nonfinite;
          continue;
        }
        max_c = std::max(max_c, c);
        violated = violated || c > spec.constraint_tolerance[row];
      }
      violations += violated;
      for (size_t c = 0; c < collision_cols.size(); ++c)
        collision_sums[c] += b.info[size_t(i) * ni + collision_cols[c]];
    }
    done_steps += active;
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json out = {{"env", cfg.env},
                        {"policy", cfg.policy},
                        {"atacom", cfg.atacom},
                        {"envs", N},
                        {"seed", cfg.seed},
                        {"threads", num_threads()},
                        {"steps", done_steps},
                        {"episodes", episodes},
                        {"terminations", terminations},
                        {"violations", violations},
                        {"max_constraint", k ? nlohmann::json(max_c) : nlohmann::json(nullptr)},
                        {"nonfinite_constraints", nonfinite},
                        {"wall_s", secs},
                        {"per_s", done_steps / secs}};
  out["collisions"] = 0;
  for (size_t c = 0; c < collision_cols.size(); ++c) {
    const std::string& name = spec.info_names[collision_cols[c]];
    out[name + "s"] = static_cast<long>(std::llround(collision_sums[c]));
  }
  return out;
}

}  // namespace atacom
