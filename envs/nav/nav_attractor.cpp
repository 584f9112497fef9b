#include "envs/nav/nav_attractor.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "envs/nav/fetch_policy.hpp"
#include "envs/nav/nav_env.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

NavAttractorParams default_nav_attractor_params() { return NavAttractorParams{}; }

void to_json(nlohmann::json& j, const NavAttractorParams& p) {
  j = nlohmann::json{{"k_v", p.k_v}, {"v_clip", p.v_clip}, {"k_w", p.k_w},
                     {"w_clip", p.w_clip}, {"v_max", p.v_max}, {"w_max", p.w_max}};
}

void from_json(const nlohmann::json& j, NavAttractorParams& p) {
  ConfigReader r(j, "nav_attractor");
  NavAttractorParams q;
  q.k_v = r.number("k_v");
  q.v_clip = r.number("v_clip");
  q.k_w = r.number("k_w");
  q.w_clip = r.number("w_clip");
  q.v_max = r.number("v_max");
  q.w_max = r.number("w_max");
  r.finish();
  for (double x : {q.k_v, q.v_clip, q.k_w, q.w_clip, q.v_max, q.w_max})
    if (!(x > 0.0)) throw std::invalid_argument("nav_attractor: gains, clips and limits must be > 0");
  p = q;
}

void nav_linear_attractor(const NavAttractorParams& p, const float* obs, int obs_dim, int N, double* actions) {
  for (int i = 0; i < N; ++i) {
    const float* o = obs + static_cast<size_t>(obs_dim) * i;
    const double ex = double(o[0]) - double(o[2]), ey = double(o[1]) - double(o[3]);
    const double yaw = std::atan2(double(o[5]), double(o[4]));
    const double heading_err = wrap_angle(std::atan2(ey, ex) - yaw);
    const double v = std::clamp(p.k_v * std::sqrt(ex * ex + ey * ey), -p.v_clip, p.v_clip);
    const double w = std::clamp(p.k_w * heading_err, -p.w_clip, p.w_clip);
    actions[2 * i] = std::clamp(v / p.v_max, -1.0, 1.0);
    actions[2 * i + 1] = std::clamp(w / p.w_max, -1.0, 1.0);
  }
}

std::unique_ptr<Policy> make_nav_attractor(const nlohmann::json& resolved_config) {
  NavConfig c;
  from_json(resolved_config, c);
  NavAttractorParams p = default_nav_attractor_params();
  p.v_max = c.tiago.v_max;
  p.w_max = c.tiago.w_max;
  return std::make_unique<NavAttractorPolicy>(p, kNavObsDim);
}

}  // namespace atacom
