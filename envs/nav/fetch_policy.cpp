#include "envs/nav/fetch_policy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "src/core/config_json.hpp"

namespace atacom {

FetchPolicyParams default_fetch_policy_params() { return FetchPolicyParams{}; }

void validate(const FetchPolicyParams& p) {
  auto positive = [](double x, const char* name) {
    if (!(x > 0.0) || !std::isfinite(x))
      throw std::invalid_argument(std::string("fetch policy: ") + name + " must be finite and > 0");
  };
  positive(p.k_v, "k_v");
  positive(p.v_max, "v_max");
  positive(p.k_w, "k_w");
  positive(p.w_max, "w_max");
  positive(p.goal_tol, "goal_tol");
  positive(p.heading_tol, "heading_tol");
  positive(p.slow_x, "slow_x");
  positive(p.slow_y, "slow_y");
  positive(p.slow_width, "slow_width");
}

void to_json(nlohmann::json& j, const FetchPolicyParams& p) {
  j = nlohmann::json{{"k_v", p.k_v},           {"v_max", p.v_max},   {"k_w", p.k_w},
                     {"w_max", p.w_max},       {"goal_tol", p.goal_tol}, {"heading_tol", p.heading_tol},
                     {"slow_x", p.slow_x},     {"slow_y", p.slow_y}, {"slow_width", p.slow_width}};
}

void from_json(const nlohmann::json& j, FetchPolicyParams& p) {
  ConfigReader r(j, "fetch_policy");
  FetchPolicyParams q;
  q.k_v = r.number("k_v");
  q.v_max = r.number("v_max");
  q.k_w = r.number("k_w");
  q.w_max = r.number("w_max");
  q.goal_tol = r.number("goal_tol");
  q.heading_tol = r.number("heading_tol");
  q.slow_x = r.number("slow_x");
  q.slow_y = r.number("slow_y");
  q.slow_width = r.number("slow_width");
  r.finish();
  validate(q);
  p = q;
}

double wrap_angle(double a) {
  // remainder() is exact in IEEE arithmetic, so the wrap is deterministic.
  return std::remainder(a, 2.0 * M_PI);
}

FetchCommand fetch_command(const FetchPolicyParams& p, const double* pose, const double* goal) {
  const double ex = goal[0] - pose[0], ey = goal[1] - pose[1];
  const double dist = std::sqrt(ex * ex + ey * ey);
  const double heading_err = wrap_angle(std::atan2(ey, ex) - pose[2]);
  FetchCommand cmd;
  cmd.arrived = dist < p.goal_tol && std::abs(heading_err) < p.heading_tol;
  cmd.v = std::min(p.k_v * dist, p.v_max);
  cmd.w = std::clamp(p.k_w * heading_err, -p.w_max, p.w_max);
  // Slow down only when the heading points out of the central zone on an
  // axis where Fetch is already outside it; the scale uses the larger excess.
  const double c = std::cos(pose[2]), s = std::sin(pose[2]);
  const double over_x = std::abs(pose[0]) - p.slow_x, over_y = std::abs(pose[1]) - p.slow_y;
  const bool out_x = over_x > 0.0 && pose[0] * c > 0.0;
  const bool out_y = over_y > 0.0 && pose[1] * s > 0.0;
  if (out_x || out_y) cmd.v *= std::clamp(1.0 - std::max(over_x, over_y) / p.slow_width, 0.0, 1.0);
  return cmd;
}

}  // namespace atacom
