#include "src/safety/filter_safelayer.hpp"

#include <iterator>
#include <stdexcept>
#include <vector>

#include "atacom/safelayer.hpp"
#include "src/safety/cbf_env.hpp"
#include "src/safety/filter_json.hpp"

namespace atacom {

namespace {

using nlohmann::json;
using filter_json::number;
using filter_json::per_row;

json safelayer_status_flags(uint32_t st) {
  json f = json::array();
  if (st & kSafeLayerInfeasible) f.push_back("infeasible");
  if (st & kSafeLayerAlphaNonFinite) f.push_back("alpha_nonfinite");
  if (st & kSafeLayerModelNonFinite) f.push_back("model_nonfinite");
  if (st & kSafeLayerIterationLimit) f.push_back("iteration_limit");
  return f;
}

}  // namespace

std::string filter_method(const json& j) {
  std::string method = "atacom";
  if (j.contains("method")) {
    const json& v = j.at("method");
    if (!v.is_string() || (v.get<std::string>() != "atacom" && v.get<std::string>() != "safelayer" &&
                           v.get<std::string>() != "cbf"))
      throw std::invalid_argument("'method' must be \"atacom\", \"safelayer\" or \"cbf\"");
    method = v.get<std::string>();
  }
  static const char* atacom_only[] = {"slack", "beta", "tol", "K_c", "basis", "bounds", "equality"};
  static const char* safelayer_only[] = {"dt", "threshold"};
  static const char* cbf_only[] = {"gamma"};
  auto refuse = [&](const char* const* keys, size_t n, const std::string& why) {
    for (size_t i = 0; i < n; ++i)
      if (j.contains(keys[i])) throw std::invalid_argument(std::string("'") + keys[i] + "' " + why);
  };
  if (method != "atacom")
    refuse(atacom_only, std::size(atacom_only), "is an ATACOM key; \"method\": \"" + method + "\" takes " +
                                                    (method == "cbf" ? "gamma" : "dt and threshold"));
  if (method != "safelayer") refuse(safelayer_only, std::size(safelayer_only), "needs \"method\": \"safelayer\"");
  if (method != "cbf") refuse(cbf_only, std::size(cbf_only), "needs \"method\": \"cbf\"");
  return method;
}

json safelayer_filter(const json& j, const ProjectorModel& model, const ProjectorBatch& B) {
  const int n = model.n, m = model.m, k = model.k;
  SafeLayerModel sm;
  if (filter_method(j) == "cbf") {
    double gamma = kCbfDefaultGamma;
    if (j.contains("gamma")) {
      gamma = number(j.at("gamma"), "gamma");
      if (!(gamma > 0)) throw std::invalid_argument("'gamma' must be > 0");
    }
    sm = cbf_model(model, gamma);
  } else {
    double dt = 1.0 / 30.0;
    if (j.contains("dt")) {
      dt = number(j.at("dt"), "dt");
      if (!(dt > 0)) throw std::invalid_argument("'dt' must be > 0");
    }
    sm = safelayer_model(model, dt, per_row<double>(j, "threshold", k, 0.0, number));
  }
  SafeLayerBatch out(sm, 1);
  safelayer_batch(sm, B, out, {.store_active_rows = true, .parallel = false});
  std::vector<double> qdot(n);
  for (int i = 0; i < n; ++i) {
    double v = model.has_drift ? B.f[i] : 0.0;
    for (int c = 0; c < m; ++c) v += B.G[size_t(i) * m + c] * out.a[c];
    qdot[i] = v;
  }
  json active = json::array();
  for (int i = 0; i < k; ++i)
    if (out.active_rows[i]) active.push_back(i);
  json res = {{"a", out.a},
              {"qdot", qdot},
              {"active", active},
              {"correction", out.correction[0]},
              {"iterations", out.iterations[0]},
              {"status", out.status[0]},
              {"status_flags", safelayer_status_flags(out.status[0])}};
  if (j.contains("id")) res["id"] = j.at("id");
  return res;
}

}  // namespace atacom
