#include "src/safety/safe_layer_env.hpp"

#include <algorithm>
#include <stdexcept>

namespace atacom {

SafeLayerEnv::SafeLayerEnv(std::unique_ptr<ControlAffineEnv> inner, const SafeLayerModel& model)
    : LayeredEnv(std::move(inner), "SafeLayerEnv", "safelayer",
                 {{"safelayer_correction", InfoReduce::Mean},
                  {"safelayer_active", InfoReduce::Mean},
                  {"safelayer_iterations", InfoReduce::Mean},
                  {"safelayer_infeasible", InfoReduce::Sum}}),
      model_(model) {
  model_.validate();
  pm_ = this->inner().projector_model();
  const EnvSpec& is = this->inner().spec();
  if (model_.m != is.act_dim || model_.k != is.num_constraints || model_.n != pm_.n || model_.p != pm_.p ||
      model_.g_form != pm_.g_form || model_.has_drift != pm_.has_drift)
    throw std::invalid_argument("SafeLayerEnv: the SafeLayer model's shapes do not match env '" + is.name + "'");
  pb_.resize(pm_, num_envs());
  out_.resize(model_, num_envs());
}

void SafeLayerEnv::take_actions(const double* actions) {
  std::copy_n(actions, size_t(num_envs()) * model_.m, pb_.alpha.data());
}

void SafeLayerEnv::correct_range(int lo, int hi) {
  inner().constraint_model(pb_, lo, hi);
  safelayer_range(model_, pb_, out_, lo, hi);
}

void SafeLayerEnv::write_info(int64_t i, float* info) const {
  info[0] = static_cast<float>(out_.correction[i]);
  info[1] = static_cast<float>(out_.active[i]);
  info[2] = static_cast<float>(out_.iterations[i]);
  info[3] = (out_.status[i] & (kSafeLayerInfeasible | kSafeLayerModelNonFinite)) ? 1.0f : 0.0f;
}

std::unique_ptr<BatchEnv> wrap_safelayer(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json&) {
  const SafeLayerModel sm = safelayer_model(inner->projector_model(), inner->spec().dt);
  return std::make_unique<SafeLayerEnv>(std::move(inner), sm);
}

}  // namespace atacom
