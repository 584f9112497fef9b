// The report's cost figures (issue 32): what a method paid in cost for its
// return. Costs are EnvBuffers::cost (0/1 per step, Safety-Gymnasium's
// convention) summed: per evaluation episode (eval_cost_mean) and over all
// training steps (train_cost). A cost axis turns logarithmic, as
// log10(1 + cost), when its largest value is 100 or more (methods that
// train with no violation sit at 0 beside ones that pay thousands).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "src/core/svg.hpp"
#include "src/experiments/report_data.hpp"
#include "src/experiments/report_stats.hpp"
#include "train/algorithms.hpp"

namespace atacom {

namespace {

// A cost axis: linear, or log10(1 + cost) from 100 on.
struct CostAxis {
  bool log = false;
  double map(double v) const { return log ? std::log10(1.0 + std::max(0.0, v)) : v; }
};

CostAxis cost_axis(double largest) { return CostAxis{largest >= 100.0}; }

// Ticks of a log10(1 + v) axis at v = 0, 1, 10, 100, ... along x (or y).
void log_ticks(SvgCanvas& c, double lo, double hi, bool along_x, double other_lo) {
  for (double v = 0, k = 0; k < 12; v = std::pow(10.0, k), ++k) {
    const double t = std::log10(1.0 + v);
    if (t < lo - 1e-9 || t > hi + 1e-9) continue;
    char b[32];
    if (v >= 1e6) std::snprintf(b, sizeof(b), "%gM", v / 1e6);
    else if (v >= 1e3) std::snprintf(b, sizeof(b), "%gk", v / 1e3);
    else std::snprintf(b, sizeof(b), "%g", v);
    if (along_x) c.label(c.px(t), c.py(other_lo) + 14, b, 10, "middle");
    else c.label(c.px(other_lo) - 5, c.py(t) + 4, b, 10, "end");
  }
}

struct Point {
  double x, y;
};

// Whether any finished run of env has the key in its summary.json. When none
// has (runs from builds before the cost keys) the panel says so instead of
// showing empty axes, which would read as "paid nothing".
bool any_run_records(const ReportData& d, const std::string& env, const std::string& key) {
  return std::any_of(d.runs.begin(), d.runs.end(), [&](const ReportRun& r) {
    return r.finished && r.cell.env == env && metric_value(r.summary, key).has_value();
  });
}

void note_if_unrecorded(SvgCanvas& c, double pw, double ph, const ReportData& d, const std::string& env,
                        const std::string& key) {
  if (!any_run_records(d, env, key))
    c.label(pw / 2, ph / 2, "no finished run of " + env + " records " + key + " (a build before the cost keys)", 11,
            "middle", "#888");
}

// One scatter panel: a point per finished run of each algorithm at
// (x_key, y_key) of its summary.json, and per algorithm a diamond at the
// IQM of each coordinate, labelled with the algorithm's name.
SvgCanvas scatter_panel(const ReportData& d, const std::string& env, const std::string& x_key, const char* x_label,
                          const std::string& y_key, const char* title, double pw, double ph) {
  std::vector<std::vector<Point>> pts(d.algos.size());
  double xmax = 0, ylo = INFINITY, yhi = -INFINITY;
  for (size_t i = 0; i < d.algos.size(); ++i)
    for (const ReportRun& r : d.runs) {
      if (!r.finished || r.cell.env != env || r.cell.algo != d.algos[i]) continue;
      const auto x = metric_value(r.summary, x_key), y = metric_value(r.summary, y_key);
      if (!x || !y) continue;
      pts[i].push_back({*x, *y});
      xmax = std::max(xmax, *x);
      ylo = std::min(ylo, *y);
      yhi = std::max(yhi, *y);
    }
  const CostAxis ax = cost_axis(xmax);
  double x0 = 0, x1 = ax.map(xmax);
  if (!std::isfinite(ylo)) ylo = 0, yhi = 1;
  pad_range(ylo, yhi);
  pad_range(x0, x1);
  x0 = std::min(x0, -0.02 * (x1 - x0));
  SvgCanvas c(pw, ph, x0, x1, ylo, yhi, 56);
  if (ax.log) {
    c.y_axis("eval return (final policy)", 5);
    c.line(x0, ylo, x1, ylo, "#444");
    log_ticks(c, x0, x1, true, ylo);
    c.label(pw / 2, ph - 12, std::string(x_label) + " (log scale)", 11, "middle");
  } else {
    c.axes(x_label, "eval return (final policy)", 5, 5);
  }
  c.label(pw / 2, 18, title, 11, "middle");
  const double r = 0.008 * (x1 - x0), dy = 0.03 * (yhi - ylo);
  for (size_t i = 0; i < pts.size(); ++i) {
    if (pts[i].empty()) continue;
    const std::string col = algorithm_color(d.algos[i]);
    std::vector<double> xs, ys;
    for (const Point& p : pts[i]) {
      c.circle(ax.map(p.x), p.y, r, col, "none", 0.45);
      xs.push_back(p.x);
      ys.push_back(p.y);
    }
    const double mx = ax.map(iqm(xs)), my = iqm(ys);
    const double hx = 2.2 * r;
    c.polygon({{mx - hx, my}, {mx, my + 1.6 * dy}, {mx + hx, my}, {mx, my - 1.6 * dy}}, col, 1.0);
    c.polyline({{mx - hx, my}, {mx, my + 1.6 * dy}, {mx + hx, my}, {mx, my - 1.6 * dy}, {mx - hx, my}}, "#000", 0.8);
    c.text(mx + 1.5 * hx, my + 0.4 * dy, d.algos[i], 9, "start", "#222");
  }
  note_if_unrecorded(c, pw, ph, d, env, x_key);
  return c;
}

}  // namespace

std::string cost_return_svg(const ReportData& d, const std::string& env) {
  const double pw = 480, ph = 340, top = 55;
  const SvgCanvas left = scatter_panel(d, env, "eval_cost_mean", "episode cost (final policy)", "eval_return_mean",
                                       "return vs cost of the final policy: a point per seed, IQM diamond", pw, ph);
  const SvgCanvas right = scatter_panel(d, env, "train_cost", "cost steps during training", "eval_return_mean",
                                        "return vs what training cost: a point per seed, IQM diamond", pw, ph);
  const std::string body = svg_placed(left, 0, top) + svg_placed(right, pw, top);
  std::vector<bool> dashed(d.algos.size(), false);
  return svg_figure(2 * pw, top + ph, env + ": cost and return (costs: steps with a row above its tolerance or a "
                                            "collision / joint-limit event)",
                    d.algos, dashed, body);
}

std::string train_cost_svg(const ReportData& d, const std::string& env) {
  const double pw = 640, ph = 360, top = 55;
  struct Series {
    std::vector<double> x, mid, low, high;
  };
  std::vector<Series> series(d.algos.size());
  double xmax = 1, largest = 0;
  for (const ReportRun& r : d.runs)
    if (r.cell.env == env && r.finished)
      for (size_t k = 0; k < r.steps.size() && k < r.train_cost.size(); ++k)
        if (std::isfinite(r.train_cost[k])) {
          xmax = std::max(xmax, r.steps[k]);
          largest = std::max(largest, r.train_cost[k]);
        }
  const CostAxis ax = cost_axis(largest);
  double lo = INFINITY, hi = -INFINITY;
  std::vector<bool> dashed(d.algos.size(), false);
  for (size_t i = 0; i < d.algos.size(); ++i) {
    if (!find_algorithm(d.algos[i]).learns()) continue;  // evaluated only: no training step
    std::map<double, std::vector<double>> at;  // env steps -> one value per seed
    int n = 0;
    for (const ReportRun& r : d.runs) {
      if (r.cell.env != env || r.cell.algo != d.algos[i] || !r.finished || r.train_cost.empty()) continue;
      ++n;
      for (size_t k = 0; k < r.train_cost.size() && k < r.steps.size(); ++k)
        if (std::isfinite(r.train_cost[k])) at[r.steps[k]].push_back(ax.map(r.train_cost[k]));
    }
    for (const auto& [x, v] : at) {
      if (int(v.size()) != n) continue;  // an evaluation every seed reached
      const Interval ci = bootstrap_iqm_ci(v, d.opts.curve_resamples, d.opts.seed,
                                           bootstrap_stream(env + "/" + d.algos[i] + "/train_cost/" + std::to_string(x)));
      series[i].x.push_back(x);
      series[i].mid.push_back(iqm(v));
      series[i].low.push_back(ci.low);
      series[i].high.push_back(ci.high);
      lo = std::min(lo, ci.low);
      hi = std::max(hi, ci.high);
    }
  }
  if (!std::isfinite(lo)) lo = 0, hi = 1;
  lo = std::min(lo, 0.0);
  pad_range(lo, hi);
  SvgCanvas c(pw, ph, 0, xmax, lo, hi, 60);
  if (ax.log) {
    c.x_axis("env steps", 5);
    c.line(0, lo, 0, hi, "#444");
    log_ticks(c, lo, hi, false, 0);
    c.label(14, ph / 2, "cost steps so far (log scale)", 11, "middle", "#222", true);
  } else {
    c.axes("env steps", "cost steps so far", 5, 5);
  }
  c.label(pw / 2, 18, "cumulative training cost: IQM over seeds, 95% bootstrap band", 11, "middle");
  for (size_t i = 0; i < series.size(); ++i) {
    const Series& s = series[i];
    if (s.x.empty()) continue;
    const std::string col = algorithm_color(d.algos[i]);
    std::vector<std::pair<double, double>> band, line;
    for (size_t k = 0; k < s.x.size(); ++k) {
      band.emplace_back(s.x[k], s.high[k]);
      line.emplace_back(s.x[k], s.mid[k]);
    }
    for (size_t k = s.x.size(); k-- > 0;) band.emplace_back(s.x[k], s.low[k]);
    c.polygon(band, col, 0.2);
    c.polyline(line, col, 2.0);
    // the name at the curve's end
    c.text(s.x.back(), s.mid.back(), d.algos[i], 9, "end", col);
  }
  note_if_unrecorded(c, pw, ph, d, env, "train_cost");
  return svg_figure(pw, top + ph, env + ": training cost (steps with cost 1, all training envs)", d.algos, dashed,
                    svg_placed(c, 0, top));
}

}  // namespace atacom
