// SafeLayerModel: validation, the factory from an env's ATACOM model, and
// the output batch.
#include <cmath>
#include <stdexcept>
#include <string>

#include "atacom/safelayer.hpp"

namespace atacom {

void SafeLayerModel::validate() const {
  auto fail = [](const std::string& msg) { throw std::invalid_argument("safelayer model: " + msg); };
  if (n < 1) fail("n (state dimension) must be >= 1");
  if (m < 1) fail("m (control dimension) must be >= 1");
  if (k < 0) fail("k (constraints) must be >= 0");
  if (p < 0) fail("p (uncontrollable state dimension) must be >= 0");
  if (g_form == GForm::Diagonal && n != m) fail("a diagonal G needs n == m");
  if (!(std::isfinite(dt) && dt > 0)) fail("dt must be finite and > 0");
  if (threshold.size() != static_cast<size_t>(k))
    fail("threshold has " + std::to_string(threshold.size()) + " entries, expected k = " + std::to_string(k));
  for (int i = 0; i < k; ++i)
    if (!std::isfinite(threshold[i])) fail("threshold[" + std::to_string(i) + "] must be finite");
}

SafeLayerModel safelayer_model(const ProjectorModel& pm, double dt, const std::vector<double>& threshold) {
  SafeLayerModel s;
  s.n = pm.n;
  s.m = pm.m;
  s.k = pm.k;
  s.p = pm.p;
  s.g_form = pm.g_form;
  s.has_drift = pm.has_drift;
  s.dt = dt;
  if (threshold.empty())
    s.threshold.assign(pm.k, 0.0);
  else if (threshold.size() == 1)
    s.threshold.assign(pm.k, threshold[0]);
  else
    s.threshold = threshold;
  s.validate();
  return s;
}

void SafeLayerBatch::resize(const SafeLayerModel& model, int n_envs) {
  N = n_envs;
  const size_t n = static_cast<size_t>(n_envs);
  a.assign(n * model.m, 0.0);
  correction.assign(n, 0.0);
  active.assign(n, 0);
  iterations.assign(n, 0);
  status.assign(n, 0);
  active_rows.clear();
}

}  // namespace atacom
