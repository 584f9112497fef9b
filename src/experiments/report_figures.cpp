// The report's SVG figures: the paper's boxplot grid and learning curves.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "src/core/svg.hpp"
#include "src/experiments/report_data.hpp"
#include "src/experiments/report_stats.hpp"
#include "train/algorithms.hpp"

namespace atacom {

// A canvas placed at (x, y) inside a bigger SVG.
std::string svg_placed(const SvgCanvas& c, double x, double y) {
  std::string s = c.str();
  const size_t at = s.find("<svg ");
  char b[64];
  std::snprintf(b, sizeof(b), "<svg x=\"%.0f\" y=\"%.0f\" ", x, y);
  return s.replace(at, 5, b);
}

std::string svg_figure(double w, double h, const std::string& title, const std::vector<std::string>& algos,
                       const std::vector<bool>& dashed, const std::string& body) {
  char head[256];
  std::snprintf(head, sizeof(head),
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\">\n"
                "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
                w, h, w, h);
  std::string s = head;
  s += "<text x=\"10\" y=\"20\" font-family=\"sans-serif\" font-size=\"15\" font-weight=\"bold\">" + svg_escape(title) +
       "</text>\n";
  double x = 10;
  for (size_t i = 0; i < algos.size(); ++i) {  // legend
    char b[512];
    std::snprintf(b, sizeof(b),
                  "<line x1=\"%.0f\" y1=\"38\" x2=\"%.0f\" y2=\"38\" stroke=\"%s\" stroke-width=\"4\"%s/>"
                  "<text x=\"%.0f\" y=\"42\" font-family=\"sans-serif\" font-size=\"12\">%s</text>\n",
                  x, x + 18, algorithm_color(algos[i]).c_str(), dashed[i] ? " stroke-dasharray=\"4 2\"" : "", x + 22,
                  svg_escape(algos[i]).c_str());
    s += b;
    x += 34 + 7.0 * double(algos[i].size());
  }
  return s + body + "</svg>\n";
}

// [lo, hi] with a margin, at least a billionth of its magnitude wide: values
// equal but for their last bits (500 and 499.99999999999994) get a readable
// axis, not one with ticks finer than the doubles can tell apart. Halves
// keep hi - lo of +-1e308 finite.
void pad_range(double& lo, double& hi) {
  const double mag = std::max({std::abs(lo), std::abs(hi), 1.0});
  const double mid = lo / 2 + hi / 2, half = std::max(hi / 2 - lo / 2, 0.5e-9 * mag);
  const double pad = 1.06 * half;
  lo = mid - pad;
  hi = mid + pad;
}

namespace {

// One panel per metric, one box per algo, a point per seed. A censored
// metric's +inf values (runs that never met the target) sit on a dashed
// "not reached" line above the finite ones; quartiles and whiskers that are
// +inf end there, and "k/n" under each box counts the runs that reached it.
std::string box_grid(const ReportData& d, const std::string& env, const std::vector<const ReportMetric*>& panels,
                     const std::string& title) {
  const double pw = 330, ph = 250, top = 55;
  const int cols = 3, rows = int((panels.size() + cols - 1) / cols);
  std::string body;
  for (size_t p = 0; p < panels.size(); ++p) {
    const ReportMetric& m = *panels[p];
    double lo = INFINITY, hi = -INFINITY;
    bool censored = false;
    std::vector<std::vector<double>> vals;
    for (const auto& a : d.algos) {
      vals.push_back(metric_values(d, env, a, m.key));
      for (double v : vals.back()) {
        if (std::isinf(v)) censored = true;
        else lo = std::min(lo, v), hi = std::max(hi, v);
      }
    }
    if (!std::isfinite(lo)) lo = 0, hi = 1;
    pad_range(lo, hi);
    double never = hi;  // the "not reached" line
    if (censored) {
      never = hi + 0.1 * (hi - lo);
      hi = never + 0.06 * (hi - lo);
    }
    const auto at = [&](double v) { return std::isinf(v) ? never : v; };
    const double na = double(d.algos.size());
    SvgCanvas c(pw, ph, 0, na, lo, hi, 42);
    c.y_axis("", 5);
    c.line(0, lo, na, lo, "#444");
    c.label(pw / 2, 18, std::string(m.label) + (m.higher_better ? "  (higher is better)" : "  (lower is better)"), 11,
            "middle");
    if (censored) {
      c.line(0, never, na, never, "#999", 1.0, "4 3");
      c.text(na, never, "not reached ", 9, "end", "#777");
    }
    for (size_t i = 0; i < vals.size(); ++i) {
      const std::vector<double>& v = vals[i];
      const double x = double(i) + 0.5;
      const std::string col = algorithm_color(d.algos[i]);
      // The algorithm's name under its box (two staggered rows: long names do not collide).
      c.label(c.px(x), c.py(lo) + (i % 2 ? 23 : 12), d.algos[i], 8.5, "middle", "#222");
      if (v.empty()) {
        c.text(x, (lo + hi) / 2, "no runs", 9, "middle", "#999");
        continue;
      }
      const double q1 = at(quantile(v, 0.25)), med = at(quantile(v, 0.5)), q3 = at(quantile(v, 0.75));
      const double mn = at(*std::min_element(v.begin(), v.end())), mx = at(*std::max_element(v.begin(), v.end()));
      c.line(x, mn, x, q1, col, 1.2);
      c.line(x, q3, x, mx, col, 1.2);
      c.line(x - 0.15, mn, x + 0.15, mn, col, 1.2);
      c.line(x - 0.15, mx, x + 0.15, mx, col, 1.2);
      c.rect(x - 0.32, q1, x + 0.32, q3, "none", col);
      c.line(x - 0.32, med, x + 0.32, med, col, 2.5);
      for (size_t k = 0; k < v.size(); ++k) {  // points: a fixed golden-ratio jitter, so figures are reproducible
        const double jitter = (std::fmod(double(k) * 0.6180339887, 1.0) - 0.5) * 0.4;
        c.circle(x + jitter, at(v[k]), 0.035, col, "none", 0.55);
      }
      if (m.censored) {
        size_t reached = 0;
        for (double y : v) reached += std::isfinite(y);
        c.label(c.px(x), c.py(lo) + 34, std::to_string(reached) + "/" + std::to_string(v.size()) + " reached", 10,
                "middle", "#444");  // below the plot area
      }
    }
    body += svg_placed(c, double(p % cols) * pw, top + double(p / cols) * ph);
  }
  std::vector<bool> dashed(d.algos.size(), false);
  return svg_figure(cols * pw, top + rows * ph, title, d.algos, dashed, body);
}

}  // namespace

std::string boxplot_svg(const ReportData& d, const std::string& env) {
  std::vector<const ReportMetric*> panels;
  for (const ReportMetric& m : report_metrics())
    if (m.boxplot) panels.push_back(&m);
  return box_grid(d, env, panels, env + ": final performance over seeds (box: quartiles, whiskers: range)");
}

std::string target_boxplot_svg(const ReportData& d, const std::string& env) {
  std::vector<const ReportMetric*> panels;
  for (const ReportMetric& m : report_metrics())
    if (m.censored) panels.push_back(&m);
  return box_grid(d, env, panels,
                  env + ": time to the quality target over seeds (runs that never reached it: on the dashed line)");
}

std::string curves_svg(const ReportData& d, const std::string& env) {
  const double pw = 480, ph = 310, top = 55;
  struct Series {
    std::vector<double> x, mid, low, high;
    bool flat = false;  // an algorithm that does not train: its one evaluation as a line
  };
  std::string body;
  std::vector<bool> dashed(d.algos.size(), false);
  double xmax = 1;
  for (const ReportRun& r : d.runs)
    if (r.cell.env == env && !r.steps.empty()) xmax = std::max(xmax, r.steps.back());
  for (int panel = 0; panel < 2; ++panel) {
    std::vector<Series> series(d.algos.size());
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < d.algos.size(); ++i) {
      std::map<double, std::vector<double>> at;  // env steps -> one value per seed
      int n = 0;
      for (const ReportRun& r : d.runs) {
        if (r.cell.env != env || r.cell.algo != d.algos[i] || !r.finished) continue;
        const std::vector<double>& y = panel == 0 ? r.eval_return : r.final_distance;
        if (y.empty()) continue;
        ++n;
        for (size_t k = 0; k < y.size() && k < r.steps.size(); ++k)
          if (std::isfinite(y[k])) at[r.steps[k]].push_back(y[k]);
      }
      Series& s = series[i];
      s.flat = !find_algorithm(d.algos[i]).learns();
      dashed[i] = s.flat;
      for (const auto& [x, v] : at) {
        if (int(v.size()) != n) continue;  // an evaluation every seed reached
        // No band from fewer than kMinSeedsForInterval seeds (the line alone).
        const Interval ci = v.size() < kMinSeedsForInterval
                                ? Interval{iqm(v), iqm(v)}
                                : bootstrap_iqm_ci(v, d.opts.curve_resamples, d.opts.seed,
                                                   bootstrap_stream(env + "/" + d.algos[i] + "/curve" +
                                                                    std::to_string(panel) + "/" + std::to_string(x)));
        s.x.push_back(x);
        s.mid.push_back(iqm(v));
        s.low.push_back(ci.low);
        s.high.push_back(ci.high);
        lo = std::min(lo, ci.low);
        hi = std::max(hi, ci.high);
      }
    }
    if (!std::isfinite(lo)) continue;  // the env has no such column (no final distance)
    pad_range(lo, hi);
    SvgCanvas c(pw, ph, 0, xmax, lo, hi, 50);
    c.axes("env steps", panel == 0 ? "eval return" : "final distance [m]", 5, 5);
    c.label(pw / 2, 18,
            std::string(panel == 0 ? "evaluation return" : "final distance to the goal") +
                ": IQM over seeds, 95% bootstrap band (none with fewer than " +
                std::to_string(kMinSeedsForInterval) + " seeds)",
            11, "middle");
    for (size_t i = 0; i < series.size(); ++i) {
      const Series& s = series[i];
      if (s.x.empty()) continue;
      const std::string col = algorithm_color(d.algos[i]);
      if (s.flat) {
        c.polygon({{0, s.low[0]}, {xmax, s.low[0]}, {xmax, s.high[0]}, {0, s.high[0]}}, col, 0.12);
        c.line(0, s.mid[0], xmax, s.mid[0], col, 1.5, "6 3");
        continue;
      }
      std::vector<std::pair<double, double>> band, line;
      for (size_t k = 0; k < s.x.size(); ++k) {
        band.emplace_back(s.x[k], s.high[k]);
        line.emplace_back(s.x[k], s.mid[k]);
      }
      for (size_t k = s.x.size(); k-- > 0;) band.emplace_back(s.x[k], s.low[k]);
      c.polygon(band, col, 0.2);
      c.polyline(line, col, 2.0);
      for (const auto& [x, y] : line) c.circle(x, y, xmax * 0.004, col);
    }
    body += svg_placed(c, panel * pw, top);
  }
  return svg_figure(2 * pw, top + ph, env + ": learning curves (dashed: policies that do not train)", d.algos, dashed,
               body);
}

}  // namespace atacom
