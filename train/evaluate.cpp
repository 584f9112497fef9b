#include "atacom/evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/json_number.hpp"

namespace atacom {

namespace {
constexpr uint64_t kEvalStream = uint64_t{2} << 32;  // episode j's action noise: stream (seed, kEvalStream + j)
constexpr uint64_t kEvalSeedSalt = 0x5EEDE7A15EEDE7A1ull;
}  // namespace

uint64_t eval_env_seed(uint64_t seed, int round) {
  return (seed ^ kEvalSeedSalt) + uint64_t(round) * 0x9E3779B97F4A7C15ull;
}

EvalResult evaluate(BatchEnv& env, Policy& policy, int episodes, uint64_t seed, bool deterministic) {
  const EnvSpec& spec = env.spec();
  const int N = env.num_envs(), D = spec.obs_dim, A = spec.act_dim, k = spec.num_constraints;
  const int ni = int(spec.info_names.size());
  if (episodes < 1) throw std::invalid_argument("evaluate: episodes must be >= 1");
  if (policy.obs_dim() != D || policy.act_dim() != A)
    throw std::invalid_argument("evaluate: the policy's obs/act dims " + std::to_string(policy.obs_dim()) + "/" +
                                std::to_string(policy.act_dim()) + " differ from env '" + spec.name + "' (" +
                                std::to_string(D) + "/" + std::to_string(A) + ")");
  if (spec.info_reduce.size() != size_t(ni))
    throw std::invalid_argument("env '" + spec.name + "' spec: info_reduce and info_names differ in length");
  // Per episode (in episode order), filled round by round.
  std::vector<double> ret(size_t(episodes), 0.0), disc(size_t(episodes), 0.0), info(size_t(episodes) * ni, 0.0);
  std::vector<int> len(size_t(episodes), 0);
  std::vector<uint8_t> term(size_t(episodes), 0);
  std::vector<int32_t> viol(size_t(episodes), 0);
  std::vector<double> cost(size_t(episodes), 0.0);
  std::vector<double> emax(size_t(episodes), -std::numeric_limits<double>::infinity());
  // Per env of the batch.
  std::vector<Rng> rngs(static_cast<size_t>(N));
  std::vector<double> actions(size_t(N) * A, 0.0), gt(size_t(N), 1.0);
  std::vector<uint8_t> done(size_t(N), 0);
  double max_c = -std::numeric_limits<double>::infinity();
  const int cap = spec.horizon > 0 ? spec.horizon : 100000;  // envs without a horizon stop here
  const EnvBuffers& b = env.buffers();
  for (int round = 0, first = 0; first < episodes; ++round, first += N) {
    const int active = std::min(N, episodes - first);
    env.seed(eval_env_seed(seed, round));  // the same start states at every evaluation
    for (int i = 0; i < N; ++i) rngs[size_t(i)].reseed(seed, kEvalStream + uint64_t(first + i));
    for (int i = 0; i < N; ++i) {
      done[size_t(i)] = i >= active;  // rows beyond the requested episodes run but are not counted
      gt[size_t(i)] = 1.0;
    }
    for (int i = 0; i < active; ++i)
      for (int c = 0; c < ni; ++c)
        info[size_t(first + i) * ni + c] =
            spec.info_reduce[size_t(c)] == InfoReduce::Max ? -std::numeric_limits<double>::infinity() : 0.0;
    int remaining = active;
    for (int step = 0; step < cap && remaining > 0; ++step) {
      policy.act(b.obs.data(), N, deterministic, rngs.data(), actions.data());
      env.step(actions.data());
      for (int i = 0; i < active; ++i) {
        if (done[size_t(i)]) continue;
        const size_t e = size_t(first + i);
        ret[e] += b.reward[size_t(i)];
        disc[e] += gt[size_t(i)] * b.reward[size_t(i)];
        gt[size_t(i)] *= spec.gamma;
        ++len[e];
        bool v = false;
        for (int r = 0; r < k; ++r) {
          const double c = b.constraints[size_t(i) * k + r];
          v = v || c > spec.constraint_tolerance[size_t(r)];
          if (std::isfinite(c)) emax[e] = std::max(emax[e], c);
        }
        viol[e] += v;
        cost[e] += b.cost[size_t(i)];
        for (int c = 0; c < ni; ++c) {
          double& acc = info[e * ni + c];
          const double x = b.info[size_t(i) * ni + c];
          switch (spec.info_reduce[size_t(c)]) {
            case InfoReduce::Last: acc = x; break;
            case InfoReduce::Sum: case InfoReduce::Mean: acc += x; break;
            case InfoReduce::Max: acc = std::max(acc, x); break;
          }
        }
        if (b.done(i)) {
          done[size_t(i)] = 1;
          term[e] = b.terminated[size_t(i)];
          --remaining;
        }
      }
    }
  }
  EvalResult r;
  const int M = episodes;
  r.episodes = M;
  r.info_names = spec.info_names;
  r.info_roles.resize(r.info_names.size());
  for (size_t c = 0; c < r.info_names.size(); ++c) r.info_roles[c] = spec.role(c);
  r.info.assign(size_t(ni), 0.0);
  double s = 0, sd = 0, s2 = 0, sd2 = 0, steps = 0;
  for (int i = 0; i < M; ++i) {
    s += ret[size_t(i)];
    sd += disc[size_t(i)];
    steps += len[size_t(i)];
    r.early_terminations += term[size_t(i)];
    r.violations += double(viol[size_t(i)]) / M;
    r.cost_mean += cost[size_t(i)] / M;
    for (int c = 0; c < ni; ++c) {
      double v = info[size_t(i) * ni + c];
      if (spec.info_reduce[size_t(c)] == InfoReduce::Mean) v /= std::max(1, len[size_t(i)]);
      r.info[size_t(c)] += v / M;
    }
  }
  r.return_mean = s / M;
  r.discounted_return_mean = sd / M;
  for (int i = 0; i < M; ++i) {
    s2 += (ret[size_t(i)] - r.return_mean) * (ret[size_t(i)] - r.return_mean);
    sd2 += (disc[size_t(i)] - r.discounted_return_mean) * (disc[size_t(i)] - r.discounted_return_mean);
  }
  r.return_std = std::sqrt(s2 / M);
  r.discounted_return_std = std::sqrt(sd2 / M);
  r.avg_episode_steps = steps / M;
  double emax_sum = 0;
  for (int i = 0; i < M; ++i) {
    max_c = std::max(max_c, emax[size_t(i)]);
    emax_sum += emax[size_t(i)];
  }
  r.max_constraint = k > 0 && std::isfinite(max_c) ? max_c : kNaN;
  r.episode_max_constraint = k > 0 && std::isfinite(emax_sum) ? emax_sum / M : kNaN;
  const int goal_col = spec.column_with(InfoRole::GoalDistance), contact_col = spec.column_with(InfoRole::AnyContact);
  r.final_distance = goal_col >= 0 ? r.info[size_t(goal_col)] : kNaN;
  r.collisions = contact_col >= 0 ? r.info[size_t(contact_col)] : kNaN;
  return r;
}

bool meets_target(const EnvTarget& target, const EvalResult& r) {
  if (!target.defined() || !(r.final_distance <= target.distance)) return false;  // NaN never meets
  for (const std::string& name : target.zero_info) {
    const auto it = std::find(r.info_names.begin(), r.info_names.end(), name);
    const size_t c = size_t(it - r.info_names.begin());
    if (it == r.info_names.end() || c >= r.info.size() || r.info[c] != 0.0) return false;
  }
  return true;
}

nlohmann::json target_json(const EnvTarget& target) {
  if (!target.defined()) return nullptr;
  return {{"distance", target.distance}, {"zero_info", target.zero_info}};
}

nlohmann::json eval_json(const EvalResult& r) {
  nlohmann::json s = {{"eval_return_mean", jnum(r.return_mean)},
                      {"eval_return_std", jnum(r.return_std)},
                      {"eval_discounted_return_mean", jnum(r.discounted_return_mean)},
                      {"eval_discounted_return_std", jnum(r.discounted_return_std)},
                      {"eval_episodes", r.episodes},
                      {"early_terminations", r.early_terminations},
                      {"avg_episode_steps", r.avg_episode_steps},
                      {"violations", r.violations},
                      {"eval_cost_mean", jnum(r.cost_mean)},
                      {"eval_max_constraint", jnum(r.max_constraint)},
                      {"eval_episode_max_constraint", jnum(r.episode_max_constraint)}};
  for (size_t c = 0; c < r.info_names.size() && c < r.info.size(); ++c) {
    const std::string& name = r.info_names[c];
    s[name] = jnum(r.info[c]);
    const InfoRole role = c < r.info_roles.size() ? r.info_roles[c] : InfoRole::Diagnostic;
    // Contact counts per episode also under the plural names the rollout
    // command and the issues use: collisions, wall_collisions, ...
    if (is_contact(role)) s[event_total_name(name, role)] = jnum(r.info[c]);
    // Episodes with a spill (HRI-Sim's per-episode 0/1 columns): a count of
    // the evaluation's episodes, "spills" and "spills_<deg>".
    // (a per-episode mean of 0/1 times the episodes: rounded, so 4 and not 3.9999999999999996).
    else if (role == InfoRole::EpisodeEvent) s[event_total_name(name, role)] = jnum(std::round(r.info[c] * r.episodes));
  }
  return s;
}
}  // namespace atacom
