#include "atacom/env.hpp"

#include "src/core/env_buffer_fields.hpp"

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

void EnvBuffers::copy_values_from(const EnvBuffers& from) { copy_field_values<EnvBufferFields>(from, *this); }

}  // namespace atacom
