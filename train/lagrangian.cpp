#include "train/lagrangian.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagLagrange = 0x4c414752;  // "LAGR"
}

LagrangianConfig default_lagrangian_config() { return LagrangianConfig{}; }

void to_json(nlohmann::json& j, const LagrangianConfig& c) {
  j = nlohmann::json{{"cost_limit", c.cost_limit}, {"lr", c.lr}, {"kp", c.kp},
                     {"ki", c.ki},                 {"kd", c.kd}, {"init", c.init}};
}

void from_json(const nlohmann::json& j, LagrangianConfig& c) {
  ConfigReader r(j, "lagrangian");
  c = default_lagrangian_config();
  r.get("cost_limit", c.cost_limit, range::non_negative());
  r.get("lr", c.lr, range::non_negative());
  r.get("kp", c.kp, range::non_negative());
  r.get("ki", c.ki, range::non_negative());
  r.get("kd", c.kd, range::non_negative());
  r.get("init", c.init, range::non_negative());
  r.finish();
}

LagrangeMultiplier::LagrangeMultiplier(const LagrangianConfig& cfg)
    : cfg_(cfg), value_(cfg.init), integral_(cfg.init) {}

void LagrangeMultiplier::update(double J) {
  const double e = J - cfg_.cost_limit;
  integral_ = std::max(0.0, integral_ + (cfg_.lr + cfg_.ki) * e);
  const double d = updates_ > 0 ? cfg_.kd * std::max(0.0, J - last_cost_) : 0.0;
  value_ = std::max(0.0, integral_ + cfg_.kp * e + d);
  last_cost_ = J;
  ++updates_;
}

void LagrangeMultiplier::save(std::ostream& out) const {
  bin::write_tag(out, kTagLagrange);
  for (double x : {value_, integral_, last_cost_}) bin::write_pod(out, x);
  bin::write_pod(out, updates_);
}

void LagrangeMultiplier::load(std::istream& in) {
  bin::expect_tag(in, kTagLagrange, "lagrange multiplier");
  const double v = bin::read_pod<double>(in, "lagrange.value");
  const double i = bin::read_pod<double>(in, "lagrange.integral");
  const double l = bin::read_pod<double>(in, "lagrange.last_cost");
  const int64_t n = bin::read_pod<int64_t>(in, "lagrange.updates");
  if (!(std::isfinite(v) && v >= 0 && std::isfinite(i) && i >= 0 && std::isfinite(l) && l >= 0 && n >= 0))
    throw std::runtime_error("Lagrange multiplier state holds a negative or non-finite value");
  value_ = v;
  integral_ = i;
  last_cost_ = l;
  updates_ = n;
}

nlohmann::json lagrangian_default_config_json() { return default_lagrangian_config(); }

nlohmann::json lagrangian_resolve_config(const nlohmann::json& section) {
  return nlohmann::json(section.get<LagrangianConfig>());
}

}  // namespace atacom
