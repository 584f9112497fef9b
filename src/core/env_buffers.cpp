#include "atacom/env.hpp"

#include <algorithm>
#include <stdexcept>

namespace atacom {

void EnvBuffers::resize(const EnvSpec& spec, int n) {
  N = n;
  const size_t sN = static_cast<size_t>(n);
  obs.assign(sN * spec.obs_dim, 0.0f);
  final_obs.assign(sN * spec.obs_dim, 0.0f);
  reward.assign(sN, 0.0f);
  cost.assign(sN, 0.0f);
  cost_continuous.assign(sN, 0.0f);
  terminated.assign(sN, 0);
  truncated.assign(sN, 0);
  constraints.assign(sN * spec.num_constraints, 0.0);
  info.assign(sN * spec.info_names.size(), 0.0f);
  episode_return.assign(sN, 0.0);
  episode_length.assign(sN, 0);
}

void EnvBuffers::copy_values_from(const EnvBuffers& from) {
  auto copy = [](const auto& src, auto& dst) {
    if (src.size() != dst.size()) throw std::logic_error("EnvBuffers::copy_values_from: shapes differ");
    std::copy(src.begin(), src.end(), dst.begin());
  };
  copy(from.obs, obs);
  copy(from.final_obs, final_obs);
  copy(from.reward, reward);
  copy(from.cost, cost);
  copy(from.cost_continuous, cost_continuous);
  copy(from.terminated, terminated);
  copy(from.truncated, truncated);
  copy(from.constraints, constraints);
  copy(from.info, info);
  copy(from.episode_return, episode_return);
  copy(from.episode_length, episode_length);
}

}  // namespace atacom
