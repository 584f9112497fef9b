#include "train/rollout.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/policy.hpp"
#include "train/policy_source.hpp"
#include "atacom/rng.hpp"
#include "src/core/limits.hpp"
#include "src/core/value_range.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

nlohmann::json run_rollout(const RolloutConfig& cfg) {
  if (!range::closed(1, limits::kMaxEnvs).contains(cfg.envs))
    throw std::invalid_argument("--envs is " + std::to_string(cfg.envs) + ", must be " +
                                range::closed(1, limits::kMaxEnvs).describe());
  if (!range::closed<long>(1, limits::kMaxSteps).contains(cfg.steps))
    throw std::invalid_argument("--steps is " + std::to_string(cfg.steps) + ", must be " +
                                range::closed<long>(1, limits::kMaxSteps).describe());
  PolicyRequest req;
  req.policy = cfg.policy;
  req.env = cfg.env;
  req.run_dir = cfg.run_dir;
  req.which = cfg.which;
  req.safety = cfg.safety;
  req.env_config = cfg.env_config;
  PolicySource src = resolve_policy_source(req);
  const std::string& env_name = src.env;
  const SafetyLayer safety = src.safety;
  auto env = make_env(EnvRequest{env_name, cfg.envs, safety, src.env_config, src.safety_params});
  const EnvSpec& spec = env->spec();
  const int N = cfg.envs, m = spec.act_dim, k = spec.num_constraints;
  Policy* policy = &src.bind(spec);
  env->seed(cfg.seed);

  // Per-env action streams, distinct from the env's own streams.
  std::vector<Rng> rng;
  rng.reserve(N);
  for (int i = 0; i < N; ++i) rng.emplace_back(cfg.seed ^ 0xA5A5A5A5ull, static_cast<uint64_t>(i) + (1ull << 40));
  std::vector<double> actions(size_t(N) * m, 0.0);

  const size_t ni = spec.info_names.size();
  std::vector<int> collision_cols;
  for (size_t c = 0; c < ni; ++c) {
    // Event counts: every contact column, and HRI-Sim's spill columns (episodes with a spill).
    if (!event_total_name(spec.info_names[c], spec.role(c)).empty()) collision_cols.push_back(int(c));
  }
  std::vector<double> collision_sums(collision_cols.size(), 0.0);
  long episodes = 0, terminations = 0, violations = 0, nonfinite = 0;
  double max_c = -INFINITY;
  const long rounds = (cfg.steps + N - 1) / N;
  long done_steps = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (long r = 0; r < rounds; ++r) {
    const int active = static_cast<int>(std::min<long>(N, cfg.steps - done_steps));
    policy->act(env->buffers().obs.data(), N, true, rng.data(), actions.data());
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
  nlohmann::json out = {{"env", env_name},
                        {"policy", cfg.policy},
                        {"safety", safety_layer_name(safety)},
                        {"atacom", safety == SafetyLayer::Atacom},
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
    const size_t col = size_t(collision_cols[c]);
    out[event_total_name(spec.info_names[col], spec.role(col))] = static_cast<long>(std::llround(collision_sums[c]));
  }
  if (const TrainedPolicy* tp = src.trained.get()) {
    out["run"] = cfg.run_dir;
    out["run_algo"] = tp->config().train.algo;
    out["run_safety"] = safety_layer_name(tp->safety());
    out["run_policy"] = run_policy_file(cfg.which);
  }
  return out;
}

}  // namespace atacom
