#include "src/experiments/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "atacom/layered_env.hpp"
#include "train/policy_source.hpp"
#include "src/core/limits.hpp"
#include "src/core/svg.hpp"
#include "src/experiments/render_scene.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

namespace {

using nlohmann::json;

// Numbers in the page at 0.1 mm (or 1e-4 of a unit): keeps the page small.
double r4(double x) { return std::isfinite(x) ? std::round(x * 1e4) / 1e4 : 0.0; }
json arr4(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(r4(x));
  return a;
}

json frame_json(const RenderFrame& f) {
  json j = {{"cap", arr4(f.capsules)}, {"sph", arr4(f.spheres)}, {"disc", arr4(f.discs)}};
  if (!f.goal.empty()) j["goal"] = arr4(f.goal);
  if (!f.axis.empty()) j["axis"] = arr4(f.axis);
  return j;
}

struct Box3 {
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  void add(const double* p, double r = 0.0) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], p[i] - r);
      hi[i] = std::max(hi[i], p[i] + r);
    }
  }
};

// World box around everything drawn (statics and every frame).
Box3 extent(const RenderScene& s, const std::vector<RenderFrame>& frames) {
  Box3 b;
  for (const char* key : {"boxes", "regions"})
    for (const json& x : s.statics[key]) {
      const std::vector<double> lo = x["min"], hi = x["max"];
      b.add(lo.data());
      b.add(hi.data());
    }
  for (const json& x : s.statics["cylinders"]) {
    const double c[3] = {x["c"][0], x["c"][1], x["z"][0]}, d[3] = {x["c"][0], x["c"][1], x["z"][1]};
    b.add(c, x["r"].get<double>());
    b.add(d, x["r"].get<double>());
  }
  for (const json& x : s.statics["spheres"]) {
    const std::vector<double> c = x["c"];
    b.add(c.data(), x["r"].get<double>());
  }
  for (const RenderFrame& f : frames) {
    for (size_t i = 0; i + 6 <= f.capsules.size(); i += 6) {
      const double r = s.capsule_radius[i / 6];
      b.add(&f.capsules[i], r);
      b.add(&f.capsules[i + 3], r);
    }
    for (size_t i = 0; i + 3 <= f.spheres.size(); i += 3)
      b.add(&f.spheres[i], std::max(s.sphere_radius[i / 3], s.sphere_margin[i / 3]));
    for (size_t i = 0; i + 3 <= f.discs.size(); i += 3) {
      const double p[3] = {f.discs[i], f.discs[i + 1], 0.0};
      b.add(p, s.disc_radius[i / 3]);
    }
    if (!f.goal.empty()) b.add(f.goal.data(), 0.05);
  }
  b.lo[2] = std::min(b.lo[2], 0.0);  // the floor is always in the side view
  return b;
}

// [lo, hi] widened to multiples of a 1-2-5 step with `ticks` intervals.
// [lo, hi] rounded out to a multiple of a round step (1, 2, 2.5 or 5 x 10^k)
// with `ticks` to `ticks + 2` steps: the tightest such range that covers it.
void nice_range(double& lo, double& hi, int ticks) {
  if (!(hi > lo)) hi = lo + 1.0;
  const double raw = (hi - lo) / (ticks + 2);
  double best_lo = lo, best_hi = hi, best_span = INFINITY;
  for (double mag = std::pow(10.0, std::floor(std::log10(raw))), decade = 0; decade < 3; mag *= 10, ++decade)
    for (double m : {1.0, 2.0, 2.5, 5.0})
      for (int n = ticks; n <= ticks + 2; ++n) {
        const double step = m * mag, l = std::floor(lo / step + 1e-9) * step, h = l + n * step;
        if (h >= hi - 1e-12 * step && h - l < best_span) best_lo = l, best_hi = h, best_span = h - l;
      }
  lo = best_lo;
  hi = best_hi;
}

constexpr int kPlotTicksX = 10, kPlotTicksY = 4, kPlotWidth = 900, kPlotMargin = 52;

// A time plot of the episode over steps [0, x1]: series clamped into
// [y0, y1], collisions as red lines, joint-limit violations as orange ones.
// Returns the SVG; the page's cursor line is placed by script.
std::string time_plot(const std::vector<std::vector<double>>& series, const std::vector<std::string>& colors,
                      const std::vector<double>& widths, double y0, double y1, const std::vector<int>& collision_steps,
                      const std::vector<int>& limit_steps, double x1, const std::string& ylabel, double zero_line) {
  SvgCanvas svg(kPlotWidth, 220, 0.0, x1, y0, y1, kPlotMargin);
  svg.axes("step", ylabel, kPlotTicksX, kPlotTicksY);
  if (zero_line > y0 && zero_line < y1) svg.line(0.0, zero_line, x1, zero_line, "#e03131", 1.0, "4 3");  // NaN: none
  for (int s : limit_steps) svg.line(s, y0, s, y1, "#f08c00", 1.5);
  for (int s : collision_steps) svg.line(s, y0, s, y1, "#e03131", 1.5);
  for (size_t k = 0; k < series.size(); ++k) {
    std::vector<std::pair<double, double>> pts;
    for (size_t i = 0; i < series[k].size(); ++i)
      pts.emplace_back(double(i + 1), std::clamp(series[k][i], y0, y1));
    svg.polyline(pts, colors[k], widths[k], k + 1 == series.size() ? 1.0 : 0.45);
  }
  std::string s = svg.str();
  // No namespace attribute: the SVG lives inline in the HTML page.
  const std::string ns = " xmlns=\"http://www.w3.org/2000/svg\"";
  if (const size_t p = s.find(ns); p != std::string::npos) s.erase(p, ns.size());
  return s;
}

}  // namespace

std::pair<double, double> constraint_plot_range(const std::vector<std::vector<double>>& rows) {
  double lo = 0.0, hi = 0.0;
  for (const auto& r : rows)
    for (double x : r)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
  const double pad = 0.05 * std::max(hi - lo, 1e-3);
  lo -= pad;
  hi += pad;
  nice_range(lo, hi, kPlotTicksY);
  return {lo, hi};
}

namespace {

std::string fmt(const char* f, double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, x);
  return buf;
}

}  // namespace

RenderResult render_episode(const RenderConfig& cfg) {
  PolicyRequest preq;
  preq.policy = cfg.policy;
  preq.env = cfg.env;
  preq.run_dir = cfg.run_dir;
  preq.which = cfg.which;
  preq.safety = cfg.safety;
  preq.env_config = cfg.env_config;
  PolicySource src = resolve_policy_source(preq);
  EnvRequest req;
  req.name = src.env;
  req.num_envs = 1;
  req.safety = src.safety;
  req.config = src.env_config;
  req.safety_params = src.safety_params;
  std::unique_ptr<BatchEnv> env = make_env(req);
  const BatchEnv* plain = env.get();
  if (const auto* layered = dynamic_cast<const LayeredEnv*>(env.get())) plain = &layered->inner();
  const std::unique_ptr<RenderRecorder> rec = make_render_recorder(*plain);
  const EnvSpec& spec = env->spec();
  // Every step is kept (frames, constraint rows) and drawn: about 11 KB of
  // memory and 1.3 KB of page each, so the episode is bounded before it runs.
  if (spec.horizon > limits::kMaxRenderSteps)
    throw std::invalid_argument("render: env.horizon is " + std::to_string(spec.horizon) + " steps, more than the " +
                                std::to_string(limits::kMaxRenderSteps) +
                                " one page shows (each step is kept and drawn); lower env.horizon (--config)");
  Policy& policy = src.bind(spec);
  env->seed(cfg.seed);
  Rng rng(cfg.seed, 0x72656e646572ull);  // the policy's own stream ("render")
  const int col_collision = spec.column_with(InfoRole::AnyContact);
  int col_limit = -1;
  for (size_t i = 0; i < spec.info_names.size(); ++i)
    if (spec.info_names[i] == "joint_limit_violation") col_limit = static_cast<int>(i);
  const int k = spec.num_constraints;

  const RenderFrame start = rec->frame(env->buffers().obs.data());
  std::vector<RenderFrame> frames;
  std::vector<std::vector<double>> rows(static_cast<size_t>(k));
  std::vector<double> reward, cmax;
  std::vector<int> collisions, limits;
  RenderResult res;
  std::vector<double> action(static_cast<size_t>(spec.act_dim), 0.0);
  const int limit = spec.horizon > 0 ? spec.horizon : 1000;
  for (int t = 0; t < limit; ++t) {
    policy.act(env->buffers().obs.data(), 1, true, &rng, action.data());
    env->step(action.data());
    const EnvBuffers& B = env->buffers();
    frames.push_back(rec->frame(B.final_obs.data()));
    double m = -INFINITY;
    for (int r = 0; r < k; ++r) {
      rows[static_cast<size_t>(r)].push_back(B.constraints[static_cast<size_t>(r)]);
      m = std::max(m, B.constraints[static_cast<size_t>(r)]);
    }
    cmax.push_back(k > 0 ? m : 0.0);
    reward.push_back(B.reward[0]);
    res.episode_return += B.reward[0];
    const bool hit = col_collision >= 0 && B.info[static_cast<size_t>(col_collision)] > 0.5f;
    if (hit) collisions.push_back(t + 1);
    if (col_limit >= 0 && B.info[static_cast<size_t>(col_limit)] > 0.5f) limits.push_back(t + 1);
    res.steps = t + 1;
    if (B.done(0)) {
      res.terminated = B.terminated[0] != 0;
      break;
    }
  }
  res.collisions = static_cast<int>(collisions.size());
  res.max_constraint = cmax.empty() ? 0.0 : *std::max_element(cmax.begin(), cmax.end());

  // The data the page's script draws from.
  const RenderScene& sc = rec->scene();
  const Box3 ext = extent(sc, frames);
  json views = json::array();
  for (const RenderScene::View& v : sc.views)
    views.push_back({{"name", v.name},
                     {"u", v.u},
                     {"v", v.v},
                     {"range", {r4(ext.lo[v.u] - 0.1), r4(ext.hi[v.u] + 0.1), r4(ext.lo[v.v] - 0.1), r4(ext.hi[v.v] + 0.1)}}});
  json fr = json::array();
  for (const RenderFrame& f : frames) fr.push_back(frame_json(f));
  std::vector<double> coll(frames.size(), 0.0);  // 1 collision, 2 joint-limit violation
  for (int s : limits) coll[static_cast<size_t>(s - 1)] = 2.0;
  for (int s : collisions) coll[static_cast<size_t>(s - 1)] = 1.0;
  double x1 = 0.0, steps_hi = std::max(1, res.steps);
  nice_range(x1, steps_hi, kPlotTicksX);
  const json data = {{"env", src.env},
                     {"policy", cfg.policy},
                     {"safety", safety_layer_name(src.safety)},
                     {"seed", cfg.seed},
                     {"dt", spec.dt},
                     {"steps", res.steps},
                     {"views", views},
                     {"statics", sc.statics},
                     {"capsule_radius", arr4(sc.capsule_radius)},
                     {"capsule_cls", sc.capsule_cls},
                     {"sphere_radius", arr4(sc.sphere_radius)},
                     {"sphere_margin", arr4(sc.sphere_margin)},
                     {"sphere_cls", sc.sphere_cls},
                     {"disc_radius", arr4(sc.disc_radius)},
                     {"disc_cls", sc.disc_cls},
                     {"axis_label", sc.axis_label},
                     {"start", frame_json(start)},
                     {"frames", fr},
                     {"reward", arr4(reward)},
                     {"max_constraint", arr4(cmax)},
                     {"collision", coll},
                     {"plot", {{"width", kPlotWidth}, {"margin", kPlotMargin}, {"x0", 0}, {"x1", steps_hi}}}};

  // Plots: every row (thin) and their maximum (bold).
  const auto [c_lo, c_hi_n] = constraint_plot_range(rows);
  std::vector<std::vector<double>> cs = rows;
  std::vector<std::string> colors(rows.size(), "#868e96");
  std::vector<double> widths(rows.size(), 0.8);
  cs.push_back(cmax);
  colors.push_back("#1c1c1c");
  widths.push_back(1.8);
  const std::string c_svg = time_plot(cs, colors, widths, c_lo, c_hi_n, collisions, limits, steps_hi,
                                      "constraint c (safe <= 0)", 0.0);
  double r_lo = 0.0, r_hi = 0.0;
  for (double x : reward) {
    r_lo = std::min(r_lo, x);
    r_hi = std::max(r_hi, x);
  }
  nice_range(r_lo, r_hi, kPlotTicksY);
  const std::string r_svg =
      time_plot({reward}, {"#1971c2"}, {1.6}, r_lo, r_hi, collisions, limits, steps_hi, "reward", NAN);

  const std::string ended = !res.terminated          ? "horizon"
                            : !collisions.empty()     ? "collision"
                            : !limits.empty()         ? "joint limit"
                                                      : "terminal state";
  const std::string title = src.env + " - " + cfg.policy + " policy - safety " + safety_layer_name(src.safety) +
                            " - seed " + std::to_string(cfg.seed) + ": " + std::to_string(res.steps) +
                            " steps (ended: " + ended + "), return " + fmt("%.1f", res.episode_return) + ", " +
                            std::to_string(res.collisions) + " collision" + (res.collisions == 1 ? "" : "s") +
                            ", max constraint " + fmt("%.4f", res.max_constraint);
  res.html = render_page_html(title, data.dump(), c_svg, r_svg);
  return res;
}

}  // namespace atacom
