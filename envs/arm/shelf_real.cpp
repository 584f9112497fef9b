#include "envs/arm/shelf_real.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "atacom/projector.hpp"
#include "atacom/safelayer.hpp"

namespace atacom {

ShelfRealConfig default_shelf_real_config() { return ShelfRealConfig{}; }

namespace {
constexpr const char* kLayerNames[] = {"none", "atacom", "safelayer", "cbf"};  // ShelfRealLayer order
}  // namespace

const char* shelf_real_layer_name(ShelfRealLayer layer) { return kLayerNames[static_cast<int>(layer)]; }

ShelfRealLayer parse_shelf_real_layer(const std::string& name) {
  for (size_t i = 0; i < std::size(kLayerNames); ++i)
    if (name == kLayerNames[i]) return static_cast<ShelfRealLayer>(i);
  throw std::invalid_argument("shelf-real: layer '" + name + "' is not one of none, atacom, safelayer, cbf");
}

void to_json(nlohmann::json& j, const ShelfRealConfig& c) {
  j = {{"trials", c.trials},
       {"targets", c.targets},
       {"success_radius", c.success_radius},
       {"hold_time", c.hold_time},
       {"max_time_per_target", c.max_time_per_target},
       {"atacom", c.layer == ShelfRealLayer::Atacom},  // kept from before "safety": the same as safety == "atacom"
       {"safety", shelf_real_layer_name(c.layer)},
       {"seed", c.seed}};
  if (c.layer == ShelfRealLayer::Cbf) j["cbf_gamma"] = c.cbf_gamma;
}

void to_json(nlohmann::json& j, const ShelfRealResult& r) {
  j = nlohmann::json::object();
  j["trials"] = r.trials;
  j["collisions"] = r.total_collisions;
  j["violation_steps"] = r.max_constraint_violations;
  j["targets"] = nlohmann::json::array();
  for (size_t t = 0; t < r.targets.size(); ++t) {
    const ShelfRealTarget& s = r.targets[t];
    j["targets"].push_back({{"target", t + 1},
                            {"final_error_mean", s.final_error_mean},
                            {"final_error_std", s.final_error_std},
                            {"success_rate", s.success_rate},
                            {"collisions", s.collisions},
                            {"time_mean", s.time_mean},
                            {"time_std", s.time_std}});
  }
}

namespace {
void mean_std(const std::vector<double>& v, double& mean, double& sd) {
  mean = sd = 0.0;
  if (v.empty()) return;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v) sd += (x - mean) * (x - mean);
  sd = std::sqrt(sd / static_cast<double>(v.size()));
}
}  // namespace

ShelfRealResult evaluate_shelf_real(const ArmEnvConfig& env_config, const ShelfRealConfig& cfg, Policy& policy) {
  if (cfg.trials < 1 || cfg.targets < 1) throw std::invalid_argument("shelf-real: trials and targets must be >= 1");
  if (policy.obs_dim() != kArmObsDim || policy.act_dim() != kArmJoints)
    throw std::invalid_argument("shelf-real: the " + policy.kind() + " policy does not fit the arm (obs/act dims " +
                                std::to_string(policy.obs_dim()) + "/" + std::to_string(policy.act_dim()) + ")");
  if (!(cfg.success_radius > 0.0 && cfg.hold_time >= 0.0 && cfg.max_time_per_target > cfg.hold_time))
    throw std::invalid_argument("shelf-real: need success_radius > 0 and max_time_per_target > hold_time >= 0");
  if (cfg.layer == ShelfRealLayer::Cbf && !(std::isfinite(cfg.cbf_gamma) && cfg.cbf_gamma > 0.0))
    throw std::invalid_argument("shelf-real: cbf_gamma must be a finite number > 0 (1/s; got " +
                                std::to_string(cfg.cbf_gamma) + ")");
  ArmEnvConfig ec = env_config;
  // A run's config may carry any dt in (0, 1): bound the trial length, so a
  // tiny dt is an error, not an hours-long loop (or an int overflow).
  constexpr int64_t kMaxTrialSteps = 1000000;
  const double trial_steps = double(cfg.targets) * cfg.max_time_per_target / ec.dt;
  if (!(trial_steps <= double(kMaxTrialSteps)))
    throw std::invalid_argument("shelf-real: targets x max_time_per_target / env.dt = " + std::to_string(trial_steps) +
                                " steps per trial, above the limit of " + std::to_string(kMaxTrialSteps) + " (env.dt " +
                                std::to_string(ec.dt) + " s is too small)");
  const int max_steps = static_cast<int>(std::lround(cfg.max_time_per_target / ec.dt));
  const int hold_steps = static_cast<int>(std::lround(cfg.hold_time / ec.dt));
  ec.horizon = cfg.targets * max_steps + 1;  // the protocol, not the horizon, ends a trial
  const int N = cfg.trials;
  ArmEnv env(ec, N);
  env.seed(cfg.seed);
  const ProjectorModel pm = env.projector_model();
  ProjectorBatch pb(pm, N);
  // SafeLayer linearises the rows over the env's control period; CBF is the
  // same QP with period 1 / gamma (src/safety/safe_layer_env.cpp, cbf_env.cpp).
  const bool qp = cfg.layer == ShelfRealLayer::SafeLayer || cfg.layer == ShelfRealLayer::Cbf;
  const SafeLayerModel sm = qp ? safelayer_model(pm, cfg.layer == ShelfRealLayer::Cbf ? 1.0 / cfg.cbf_gamma : ec.dt)
                               : SafeLayerModel{};
  SafeLayerBatch qp_out;
  if (qp) qp_out.resize(sm, N);
  const EnvSpec& spec = env.spec();
  const size_t ni = spec.info_names.size();

  // Targets: the env's first goal, then further goals from each env's stream.
  std::vector<double> targets(static_cast<size_t>(N) * cfg.targets * 3);
  for (int e = 0; e < N; ++e) {
    for (int r = 0; r < 3; ++r) targets[(e * cfg.targets) * 3 + r] = env.goal()[e * 3 + r];
    for (int t = 1; t < cfg.targets; ++t)
      env.sample_goal(e, &targets[(e * cfg.targets + t - 1) * 3], &targets[(e * cfg.targets + t) * 3]);
  }

  ShelfRealResult res;
  res.trials = N;
  res.targets.resize(cfg.targets);
  std::vector<uint8_t> dead(N, 0);  // trial ended by a collision
  std::vector<double> action(static_cast<size_t>(N) * kArmJoints);
  std::vector<float> obs(env.buffers().obs);
  std::vector<Rng> rngs;
  for (int e = 0; e < N; ++e) rngs.emplace_back(cfg.seed, (uint64_t{7} << 32) | uint64_t(e));
  for (int t = 0; t < cfg.targets; ++t) {
    for (int e = 0; e < N; ++e)
      if (!dead[e]) env.set_goal(e, &targets[(e * cfg.targets + t) * 3]);
    std::vector<int> inside(N, 0), done_at(N, -1);
    std::vector<double> err(N, 0.0);
    std::vector<uint8_t> hit(N, 0);
    const std::vector<uint8_t> attempted = [&] {
      std::vector<uint8_t> a(N);
      for (int e = 0; e < N; ++e) a[e] = !dead[e];
      return a;
    }();
    for (int s = 0; s < max_steps; ++s) {
      bool active = false;
      for (int e = 0; e < N; ++e) active = active || (!dead[e] && done_at[e] < 0);
      if (!active) break;
      obs = env.buffers().obs;
      policy.act(obs.data(), N, true, rngs.data(), action.data());
      if (cfg.layer != ShelfRealLayer::None) {
        pb.alpha = action;
        env.constraint_model(pb, 0, N);
        if (qp) {
          safelayer_batch(sm, pb, qp_out);
          action = qp_out.a;
        } else {
          project_batch(pm, pb);
          action = pb.a;
        }
      }
      // Envs that finished this target (or died) hold still.
      for (int e = 0; e < N; ++e)
        if (dead[e] || done_at[e] >= 0)
          for (int j = 0; j < kArmJoints; ++j) action[e * kArmJoints + j] = 0.0;
      env.step(action.data());
      const EnvBuffers& b = env.buffers();
      for (int e = 0; e < N; ++e) {
        if (dead[e] || done_at[e] >= 0) continue;
        bool viol = false;
        for (int r = 0; r < kArmRows; ++r) viol = viol || b.constraints[e * kArmRows + r] > spec.constraint_tolerance[r];
        res.max_constraint_violations += viol;
        const double d = b.info[e * ni + 3];  // distance at the reached state
        err[e] = d;
        if (b.terminated[e]) {
          hit[e] = 1;
          dead[e] = 1;
          continue;
        }
        inside[e] = d < cfg.success_radius ? inside[e] + 1 : 0;
        if (inside[e] >= hold_steps) done_at[e] = s + 1;
      }
    }
    ShelfRealTarget& st = res.targets[t];
    std::vector<double> errs, times;
    int ok = 0;
    for (int e = 0; e < N; ++e) {
      if (attempted[e]) errs.push_back(err[e]);  // trials that crashed earlier never start this target
      if (done_at[e] >= 0) {
        ++ok;
        times.push_back(done_at[e] * ec.dt);
      }
      st.collisions += hit[e];
    }
    mean_std(errs, st.final_error_mean, st.final_error_std);
    mean_std(times, st.time_mean, st.time_std);
    st.success_rate = static_cast<double>(ok) / N;
    res.total_collisions += st.collisions;
  }
  return res;
}

}  // namespace atacom
