// ProjectorModel: validation, JSON round trip, and the slack/scale helpers
// shared by the batched kernel and the per-env reference.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

std::string slack_type_name(SlackType t) {
  switch (t) {
    case SlackType::SoftCorner: return "softcorner";
    case SlackType::Exponential: return "exponential";
    case SlackType::Quadratic: return "quadratic";
  }
  return "?";
}

SlackType parse_slack_type(const std::string& s) {
  if (s == "softcorner") return SlackType::SoftCorner;
  if (s == "exponential") return SlackType::Exponential;
  if (s == "quadratic") return SlackType::Quadratic;
  throw std::invalid_argument("unknown slack type '" + printable_text(s) + "' (softcorner, exponential, quadratic)");
}

std::string basis_type_name(BasisType t) { return t == BasisType::Smooth ? "smooth" : "projected"; }

BasisType parse_basis_type(const std::string& s) {
  if (s == "projected") return BasisType::Projected;
  if (s == "smooth") return BasisType::Smooth;
  throw std::invalid_argument("unknown basis '" + printable_text(s) + "' (projected, smooth)");
}

std::string bound_rule_name(BoundRule r) {
  return r == BoundRule::CorrectionFirst ? "correction_first" : "tangent_scale";
}

BoundRule parse_bound_rule(const std::string& s) {
  if (s == "tangent_scale") return BoundRule::TangentScale;
  if (s == "correction_first") return BoundRule::CorrectionFirst;
  throw std::invalid_argument("unknown bound rule '" + printable_text(s) + "' (tangent_scale, correction_first)");
}

int ProjectorModel::num_equality() const {
  int e = 0;
  for (auto v : equality) e += v != 0;
  return e;
}

void ProjectorModel::validate() const {
  auto fail = [](const std::string& msg) { throw std::invalid_argument("projector model: " + msg); };
  if (n < 1) fail("n (state dimension) must be >= 1");
  if (m < 1) fail("m (control dimension) must be >= 1");
  if (k < 0) fail("k (constraints) must be >= 0");
  if (p < 0) fail("p (uncontrollable state dimension) must be >= 0");
  const size_t sk = static_cast<size_t>(k);
  if (slack.size() != sk) fail("slack has " + std::to_string(slack.size()) + " entries, expected k = " + std::to_string(k));
  if (beta.size() != sk) fail("beta has " + std::to_string(beta.size()) + " entries, expected k = " + std::to_string(k));
  if (tol.size() != sk) fail("tol has " + std::to_string(tol.size()) + " entries, expected k = " + std::to_string(k));
  if (equality.size() != sk)
    fail("equality has " + std::to_string(equality.size()) + " entries, expected k = " + std::to_string(k));
  for (int i = 0; i < k; ++i) {
    if (!(std::isfinite(beta[i]) && beta[i] > 0)) fail("beta[" + std::to_string(i) + "] must be finite and > 0");
    if (!(std::isfinite(tol[i]) && tol[i] > 0 && tol[i] < 1))
      fail("tol[" + std::to_string(i) + "] must be in (0, 1)");
  }
  if (!(std::isfinite(K_c) && K_c >= 0)) fail("K_c must be finite and >= 0");
  if (g_form == GForm::Diagonal && n != m) fail("diagonal G needs n == m");
  if (num_equality() > m) fail("more equality rows than controls: the tangent space would be empty");
}

ProjectorModel default_projector_model(int n, int m, int k, int p) {
  ProjectorModel model;
  model.n = n;
  model.m = m;
  model.k = k;
  model.p = p;
  model.slack.assign(static_cast<size_t>(std::max(k, 0)), SlackType::SoftCorner);
  model.beta.assign(static_cast<size_t>(std::max(k, 0)), 3.0);
  model.tol.assign(static_cast<size_t>(std::max(k, 0)), 1e-6);
  model.equality.assign(static_cast<size_t>(std::max(k, 0)), 0);
  model.bounds = BoundRule::CorrectionFirst;  // issue 31: a per-component clip of the correction let a row oscillate
  return model;
}

void to_json(nlohmann::json& j, const ProjectorModel& model) {
  std::vector<std::string> slack;
  for (auto s : model.slack) slack.push_back(slack_type_name(s));
  std::vector<bool> eq;
  for (auto e : model.equality) eq.push_back(e != 0);
  j = nlohmann::json{{"n", model.n},
                     {"m", model.m},
                     {"k", model.k},
                     {"p", model.p},
                     {"slack", slack},
                     {"beta", model.beta},
                     {"tol", model.tol},
                     {"equality", eq},
                     {"K_c", model.K_c},
                     {"basis", basis_type_name(model.basis)},
                     {"bounds", bound_rule_name(model.bounds)},
                     {"g_form", model.g_form == GForm::Diagonal ? "diagonal" : "dense"},
                     {"has_drift", model.has_drift}};
}

void from_json(const nlohmann::json& j, ProjectorModel& model) {
  static const char* known[] = {"n", "m", "k", "p", "slack", "beta", "tol", "equality",
                                "K_c", "basis", "bounds", "g_form", "has_drift"};
  if (!j.is_object()) throw std::invalid_argument("projector model: expected a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find_if(std::begin(known), std::end(known), [&](const char* s) { return it.key() == s; }) ==
        std::end(known))
      throw std::invalid_argument("projector model: unknown key '" + printable_text(it.key()) + "'");
  }
  ProjectorModel out = default_projector_model(j.at("n").get<int>(), j.at("m").get<int>(), j.at("k").get<int>(),
                                               j.value("p", 0));
  if (j.contains("slack")) {
    out.slack.clear();
    for (const auto& s : j.at("slack")) out.slack.push_back(parse_slack_type(s.get<std::string>()));
  }
  if (j.contains("beta")) out.beta = j.at("beta").get<std::vector<double>>();
  if (j.contains("tol")) out.tol = j.at("tol").get<std::vector<double>>();
  if (j.contains("equality")) {
    out.equality.clear();
    for (const auto& e : j.at("equality")) out.equality.push_back(e.get<bool>() ? 1 : 0);
  }
  if (j.contains("K_c")) out.K_c = j.at("K_c").get<double>();
  if (j.contains("basis")) out.basis = parse_basis_type(j.at("basis").get<std::string>());
  if (j.contains("bounds")) out.bounds = parse_bound_rule(j.at("bounds").get<std::string>());
  if (j.contains("g_form")) {
    const auto g = j.at("g_form").get<std::string>();
    if (g == "dense") out.g_form = GForm::Dense;
    else if (g == "diagonal") out.g_form = GForm::Diagonal;
    else throw std::invalid_argument("projector model: g_form must be 'dense' or 'diagonal'");
  }
  if (j.contains("has_drift")) out.has_drift = j.at("has_drift").get<bool>();
  out.validate();
  model = std::move(out);
}

ProjectorBatch::ProjectorBatch(const ProjectorModel& model, int n_envs) { resize(model, n_envs); }

void ProjectorBatch::resize(const ProjectorModel& model, int n_envs) {
  N = n_envs;
  const size_t sN = static_cast<size_t>(n_envs);
  const size_t n = model.n, m = model.m, k = model.k, p = model.p;
  f.assign(sN * n, 0.0);
  G.assign(sN * (model.g_form == GForm::Diagonal ? n : n * m), 0.0);
  c.assign(sN * k, 0.0);
  Jq.assign(sN * k * n, 0.0);
  Jx.assign(sN * k * p, 0.0);
  xdot.assign(sN * p, 0.0);
  alpha.assign(sN * m, 0.0);
  a.assign(sN * m, 0.0);
  slack_u.assign(sN * k, 0.0);
  s.assign(sN * k, 0.0);
  lambda.assign(sN, 1.0);
  status.assign(sN, 0);
  Na.clear();
}

double slack_value(double c, double tol) { return std::max(-c, tol); }

double slack_rate(SlackType type, double s, double beta, double tol) {
  switch (type) {
    case SlackType::SoftCorner: return std::min(std::exp(beta * s), 1.0 / tol) - 1.0;
    case SlackType::Exponential: return beta * s;
    case SlackType::Quadratic: return std::sqrt(2.0 * s);
  }
  return 0.0;
}

double tangent_scale(const double* b, const double* t, int m, bool* bias_out) {
  double lambda = 1.0;
  bool out = false;
  for (int i = 0; i < m; ++i) {
    if (b[i] > 1.0 || b[i] < -1.0) out = true;
    // Sign-aware: only the bound the tangential part moves towards limits it.
    if (t[i] > 0.0) lambda = std::min(lambda, (1.0 - b[i]) / t[i]);
    else if (t[i] < 0.0) lambda = std::min(lambda, (-1.0 - b[i]) / t[i]);
  }
  if (out || !(lambda > 0.0)) lambda = 0.0;
  if (bias_out) *bias_out = out;
  return lambda;
}

}  // namespace atacom
