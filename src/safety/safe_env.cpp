#include "atacom/safe_env.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace atacom {

SafeEnv::SafeEnv(std::unique_ptr<ControlAffineEnv> inner, const ProjectorModel& model)
    : LayeredEnv(std::move(inner), "SafeEnv", "projector",
                 {{"atacom_lambda", InfoReduce::Mean}, {"atacom_bias_out", InfoReduce::Sum}}),
      model_(model) {
  model_.validate();
  const EnvSpec& is = this->inner().spec();
  if (model_.m != is.act_dim)
    throw std::invalid_argument("SafeEnv: projector has m = " + std::to_string(model_.m) + " controls but env '" +
                                is.name + "' has " + std::to_string(is.act_dim) + " actions");
  if (model_.k != is.num_constraints)
    throw std::invalid_argument("SafeEnv: projector has k = " + std::to_string(model_.k) + " rows but env '" +
                                is.name + "' reports " + std::to_string(is.num_constraints) + " constraints");
  pb_.resize(model_, num_envs());
}

void SafeEnv::take_actions(const double* alpha) {
  std::copy_n(alpha, size_t(num_envs()) * model_.m, pb_.alpha.data());
}

void SafeEnv::correct_range(int lo, int hi) {
  inner().constraint_model(pb_, lo, hi);
  // The env only needs a (and lambda/status); skipping the slack outputs
  // saves a fifth of the kernel's memory traffic.
  project_range(model_, pb_, lo, hi, {.store_slack = false});
}

void SafeEnv::write_info(int64_t i, float* info) const {
  info[0] = static_cast<float>(pb_.lambda[i]);
  info[1] = (pb_.status[i] & (kStatusBiasOutOfBounds | kStatusModelNonFinite)) ? 1.0f : 0.0f;
}

std::unique_ptr<BatchEnv> wrap_atacom(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json&) {
  const ProjectorModel pm = inner->projector_model();
  return std::make_unique<SafeEnv>(std::move(inner), pm);
}

}  // namespace atacom
