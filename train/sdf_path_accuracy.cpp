#include "train/sdf_path_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "atacom/safe_env.hpp"
#include "atacom/safety_layer.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "envs/arm/tiago_kinematics.hpp"
#include "kernels/human_rows_lanes.hpp"

namespace atacom {

using json = nlohmann::json;

namespace {

struct Bin {
  long n = 0;
  double sum = 0, max = 0;
  std::vector<double> ang;
  void add(double err, double angle) {
    ++n, sum += err, max = std::max(max, err);
    ang.push_back(angle);
  }
  json to_json() {
    std::sort(ang.begin(), ang.end());
    double am = 0;
    for (double a : ang) am += a;
    auto pct = [&](double q) { return ang.empty() ? 0.0 : ang[std::min(ang.size() - 1, size_t(q * double(ang.size() - 1) + 0.5))]; };
    return {{"points", n},
            {"mean_abs_err", n ? sum / double(n) : 0.0},
            {"max_abs_err", max},
            {"grad_angle_mean_deg", ang.empty() ? 0.0 : am / double(ang.size())},
            {"grad_angle_p95_deg", pct(0.95)}};
  }
};

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  if (a.norm() == 0 || b.norm() == 0) return 180.0;
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace

json sdf_path_accuracy(const SdfPathConfig& c) {
  if (c.env != "table" && c.env != "shelf" && c.env != "hri")
    throw std::invalid_argument("sdf path accuracy: env '" + c.env + "', must be table, shelf or hri");
  if (c.envs < 1 || c.steps < c.envs) throw std::invalid_argument("sdf path accuracy: need envs >= 1 and steps >= envs");
  json cfg = sdf_flag_override(c.env, "learned");
  if (c.env == "hri") cfg["hri"] = {{"split", c.split}};
  const SafetyLayer layer = parse_safety_layer(c.safety);
  if (layer != SafetyLayer::Atacom && layer != SafetyLayer::None)
    throw std::invalid_argument("sdf path accuracy: safety '" + c.safety + "', must be atacom or none");
  auto env = make_env({c.env, c.envs, layer, cfg});
  auto* safe = dynamic_cast<SafeEnv*>(env.get());
  const auto* arm = dynamic_cast<const ArmEnv*>(safe ? &safe->inner() : env.get());
  if (!arm) throw std::logic_error("sdf path accuracy: not an arm env");
  if (c.field != "obstacle" && c.field != "body")
    throw std::invalid_argument("sdf path accuracy: field '" + c.field + "', must be obstacle or body");
  const bool body = c.field == "body";
  const bool hri = arm->hri() && !body;  // the human's field (pose-conditioned, per env)
  std::shared_ptr<LearnedObstacle> obs;
  std::shared_ptr<LearnedHuman> hum;
  if (hri) hum = load_arm_learned_human(arm->config().sdf);
  else if (body) obs = load_arm_learned_body(arm->config().sdf, arm->config().torso_lift);
  else obs = load_arm_learned_obstacle(arm->config().sdf, arm->config().scene);
  if (!hum && !obs) throw std::logic_error("sdf path accuracy: no learned field for '" + c.field + "'");
  RedsdfBatch& net = hri ? *hum->batch : *obs->batch;
  const double margin = hri ? hum->margin : obs->margin;
  // The body's pose input (the torso lift) is the same for every point.
  const int N = c.envs, P = hri ? kHumanDofs : int(obs->pose.size());
  const ShapeUnion& analytic = body ? arm->scene().body : arm->scene().obstacle;
  std::vector<float> pts(size_t(N) * kArmPoi * 3), pose(size_t(N) * kArmPoi * P), d(size_t(N) * kArmPoi),
      g(size_t(N) * kArmPoi * 3);
  std::vector<double> da(size_t(N) * kArmPoi), dex(da.size()), ga(3 * da.size()), yaw(static_cast<size_t>(N));
  std::vector<uint8_t> use(static_cast<size_t>(N));
  env->seed(c.seed);
  env->reset();
  Rng rng(c.seed, 0x9a7);
  const int m = env->spec().act_dim;
  std::vector<double> a(size_t(N) * m);
  Bin near, mid, far, all;
  double over = -1e300, over_exact = -1e300, min_a = 1e300;
  long inside = 0, clear_inside = 0, points = 0;
  const long iters = c.steps / N;
  for (long t = 0; t < iters; ++t) {
    for (double& x : a) x = rng.uniform(-1.0, 1.0);
    env->step(a.data());
    for (int e = 0; e < N; ++e) {
      use[size_t(e)] = !arm->buffers().done(e);
      if (!use[size_t(e)]) continue;
      const ArmFkResult fk = arm_fk_reference(arm->model(), Eigen::Map<const ArmQ>(&arm->q()[size_t(e) * kArmJoints]));
      for (int i = 0; i < kArmPoi; ++i) {
        const size_t r = size_t(e) * kArmPoi + size_t(i);
        const Eigen::Vector3d p = fk.poi[size_t(i)];
        Eigen::Vector3d gr;
        if (hri) {
          const double* x = &arm->humans().pose[size_t(e) * kHumanPoseDim];
          const double* cap = &arm->humans().cap[size_t(e) * kHumanCapsules * 6];
          double A[kHumanCapsules][3], B[kHumanCapsules][3], V[kHumanCapsules][3] = {}, ddt = 0, de = 0;
          for (int k = 0; k < kHumanCapsules; ++k)
            for (int q = 0; q < 3; ++q) A[k][q] = cap[k * 6 + q], B[k][q] = cap[k * 6 + 3 + q];
          const HumanFkConst& hk = arm->human_model().fk;
          da[r] = human_impl::human_point_distance<double>(A, B, V, V, hk.cap_inv_len2, hk.cap_radius,
                                                           arm->config().hri.human_blend, p.data(), gr.data(), ddt, de);
          dex[r] = de;
          const double cs = std::cos(x[3]), sn = std::sin(x[3]), dx = p.x() - x[0], dy = p.y() - x[1];
          yaw[size_t(e)] = x[3];
          pts[3 * r] = float(cs * dx + sn * dy), pts[3 * r + 1] = float(-sn * dx + cs * dy), pts[3 * r + 2] = float(p.z() - x[2]);
          for (int k = 0; k < P; ++k) pose[r * size_t(P) + size_t(k)] = float(x[kHumanRootDofs + k]);
        } else {
          da[r] = union_distance(analytic, p, &gr);
          ShapeUnion ex = analytic;
          ex.blend = 0.0;
          dex[r] = union_distance_exact(ex, p);
          const Eigen::Vector3d po = obs->R.transpose() * (p - obs->t);
          for (int k = 0; k < 3; ++k) pts[3 * r + size_t(k)] = float(po(k));
          for (int k = 0; k < P; ++k) pose[r * size_t(P) + size_t(k)] = obs->pose[size_t(k)];
        }
        for (int k = 0; k < 3; ++k) ga[3 * r + size_t(k)] = gr(k);
      }
    }
    net.evaluate(pts.data(), P ? pose.data() : nullptr, false, int64_t(N) * kArmPoi, d.data(), g.data());
    for (int e = 0; e < N; ++e) {
      if (!use[size_t(e)]) continue;
      for (int i = 0; i < kArmPoi; ++i) {
        const size_t r = size_t(e) * kArmPoi + size_t(i);
        const Eigen::Vector3d gl(g[3 * r], g[3 * r + 1], g[3 * r + 2]);
        Eigen::Vector3d gw;
        if (hri) {
          const double cs = std::cos(yaw[size_t(e)]), sn = std::sin(yaw[size_t(e)]);
          gw = {cs * gl.x() - sn * gl.y(), sn * gl.x() + cs * gl.y(), gl.z()};
        } else {
          gw = obs->R * gl;
        }
        const double dl = d[r], y = da[r], err = std::abs(dl - y);
        const double ang = angle_deg(gw, Eigen::Vector3d(ga[3 * r], ga[3 * r + 1], ga[3 * r + 2]));
        ++points;
        all.add(err, ang);
        (std::abs(y) < 0.1 ? near : y > 0.3 ? far : mid).add(err, ang);
        if (y >= -0.15 && y <= 0.3) over = std::max(over, dl - y), over_exact = std::max(over_exact, dl - dex[r]);
        min_a = std::min(min_a, y);
        if (y < 0) ++inside, clear_inside += dl > margin;
      }
    }
  }
  return {{"env", c.env},
          {"field", c.field},
          {"object", hri ? "human" : body ? "tiago" : c.env},
          {"steps", iters * N},
          {"envs", N},
          {"seed", c.seed},
          {"split", hri ? c.split : "-"},
          {"safety", c.safety},
          {"points", points},
          {"margin", margin},
          {"near", near.to_json()},
          {"mid", mid.to_json()},
          {"far", far.to_json()},
          {"all", all.to_json()},
          {"max_overestimate_band", over},
          {"max_over_exact", over_exact},
          {"min_analytic", min_a},
          {"inside_points", inside},
          {"clear_while_inside", clear_inside}};
}

}  // namespace atacom
