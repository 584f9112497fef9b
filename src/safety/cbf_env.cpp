#include "src/safety/cbf_env.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "atacom/control_affine_env.hpp"

namespace atacom {

SafeLayerModel cbf_model(const ProjectorModel& pm, double gamma) {
  if (!(std::isfinite(gamma) && gamma > 0))
    throw std::invalid_argument("cbf: gamma must be a finite number > 0 (got " + std::to_string(gamma) + ")");
  return safelayer_model(pm, 1.0 / gamma);
}

CbfEnv::CbfEnv(std::unique_ptr<ControlAffineEnv> inner, double gamma)
    : LayeredEnv(std::move(inner), "CbfEnv", "cbf",
                 {{"cbf_correction", InfoReduce::Mean},
                  {"cbf_active", InfoReduce::Mean},
                  {"cbf_iterations", InfoReduce::Mean},
                  {"cbf_infeasible", InfoReduce::Sum}}),
      gamma_(gamma) {
  pm_ = this->inner().projector_model();
  model_ = cbf_model(pm_, gamma);
  pb_.resize(pm_, num_envs());
  out_.resize(model_, num_envs());
}

void CbfEnv::take_actions(const double* actions) {
  std::copy_n(actions, size_t(num_envs()) * model_.m, pb_.alpha.data());
}

void CbfEnv::correct_range(int lo, int hi) {
  inner().constraint_model(pb_, lo, hi);
  safelayer_range(model_, pb_, out_, lo, hi);
}

void CbfEnv::write_info(int64_t i, float* info) const {
  info[0] = static_cast<float>(out_.correction[i]);
  info[1] = static_cast<float>(out_.active[i]);
  info[2] = static_cast<float>(out_.iterations[i]);
  info[3] = (out_.status[i] & (kSafeLayerInfeasible | kSafeLayerModelNonFinite)) ? 1.0f : 0.0f;
}

nlohmann::json cbf_default_params(const std::string&) { return {{"gamma", kCbfDefaultGamma}}; }

std::unique_ptr<BatchEnv> wrap_cbf(std::unique_ptr<ControlAffineEnv> inner, const nlohmann::json& params) {
  const nlohmann::json& g = params.at("gamma");
  if (!g.is_number() || !std::isfinite(g.get<double>()) || !(g.get<double>() > 0))
    throw std::invalid_argument("config key 'cbf.gamma' must be a finite number > 0 (1/s; default 10)");
  return std::make_unique<CbfEnv>(std::move(inner), g.get<double>());
}

}  // namespace atacom
