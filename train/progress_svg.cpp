#include "train/progress_svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <utility>
#include <vector>

#include "src/core/svg.hpp"

namespace atacom {

namespace {

struct Curve {
  std::string label;
  std::vector<double> y;
  std::string color;
};

constexpr double kPanelW = 480, kPanelH = 300;
const char* const kColors[] = {"#d62728", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};

// One panel: the curves against env steps (NaN points skipped), an optional
// band (lo, hi) around the first curve, a legend when there is more than one curve.
std::string panel(const std::string& title, const std::string& ylabel, const std::vector<double>& x,
                  const std::vector<Curve>& curves, const std::vector<double>* band_lo = nullptr,
                  const std::vector<double>* band_hi = nullptr) {
  double x1 = 1, y0 = INFINITY, y1 = -INFINITY;
  for (double v : x)
    if (std::isfinite(v)) x1 = std::max(x1, v);
  auto extend = [&](const std::vector<double>& ys) {
    for (double v : ys)
      if (std::isfinite(v)) y0 = std::min(y0, v), y1 = std::max(y1, v);
  };
  for (const Curve& c : curves) extend(c.y);
  if (band_lo) extend(*band_lo), extend(*band_hi);
  if (!(y0 <= y1)) y0 = 0, y1 = 1;  // no finite value: an empty frame
  if (y1 - y0 < 1e-6 * std::max(1.0, std::abs(y1))) {  // flat to 6 digits: a line in a padded frame
    const double pad = std::max(1.0, std::abs(y1) * 0.1);
    y0 -= y0 >= 0 && y0 < pad ? y0 : pad;  // a flat zero line sits on the axis
    y1 += pad;
  }
  // Round the range out to a tick step (1, 2 or 5 x 10^k), about 5 ticks.
  const double raw = (y1 - y0) / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw <= mag ? mag : raw <= 2 * mag ? 2 * mag : raw <= 5 * mag ? 5 * mag : 10 * mag;
  const double lo = std::floor(y0 / step) * step;
  const int ticks = std::max(1, int(std::ceil((y1 - lo) / step - 1e-9)));
  SvgCanvas svg(kPanelW, kPanelH, 0.0, x1, lo, lo + ticks * step, 56);
  svg.axes("env steps", ylabel, 5, ticks);
  svg.label(kPanelW / 2, 22, title, 13, "middle");
  auto points = [&](const std::vector<double>& ys) {
    std::vector<std::pair<double, double>> p;
    for (size_t i = 0; i < x.size() && i < ys.size(); ++i)
      if (std::isfinite(x[i]) && std::isfinite(ys[i])) p.emplace_back(x[i], ys[i]);
    return p;
  };
  if (band_lo && !curves.empty()) {
    svg.polyline(points(*band_hi), curves[0].color, 1.0, 0.35);
    svg.polyline(points(*band_lo), curves[0].color, 1.0, 0.35);
  }
  for (size_t c = 0; c < curves.size(); ++c) {
    const auto p = points(curves[c].y);
    svg.polyline(p, curves[c].color, 2.0);
    for (const auto& [px, py] : p) svg.circle(px, py, 0.005 * x1, curves[c].color);  // one dot per evaluation
    if (curves.size() > 1) {
      svg.label(66, 40 + 14 * double(c), curves[c].label, 10, "start", curves[c].color);
    }
  }
  return svg.str();
}

}  // namespace

std::string progress_svg(const std::string& title, const ProgressFile& p, bool constrained) {
  // The values as progress.csv holds them (9 digits): a resumed run reads its
  // first rows back from the file, and must draw the same picture as a run
  // that kept them in memory.
  auto col = [&](const std::string& name) {
    std::vector<double> v = p.series(p.column(name));
    for (double& x : v) x = std::strtod(ProgressFile::format(x).c_str(), nullptr);
    return v;
  };
  const std::vector<double> steps = col("env_steps");
  std::vector<std::string> panels;

  const std::vector<double> mean = col("eval_return_mean"), sd = col("eval_return_std");
  std::vector<double> lo(mean.size()), hi(mean.size());
  for (size_t i = 0; i < mean.size(); ++i) {
    const double s = std::isfinite(sd[i]) ? sd[i] : 0.0;
    lo[i] = mean[i] - s;
    hi[i] = mean[i] + s;
  }
  panels.push_back(panel("evaluation return", "return (mean, mean +- std)", steps,
                         {{"eval return", mean, "#1f77b4"}}, &lo, &hi));
  if (p.column("final_distance") >= 0)
    panels.push_back(panel("final distance to the goal (evaluation)", "m (mean over episodes)", steps,
                           {{"final distance", col("final_distance"), "#2ca02c"}}));
  if (constrained) {
    // Training: running totals over every training step so far.
    std::vector<Curve> train;
    size_t color = 0;
    for (const std::string& c : p.columns())
      if (c.rfind("train_", 0) == 0 && c.size() >= 9 && c.compare(c.size() - 9, 9, "collision") == 0)
        train.push_back({c.substr(6) + "s", col(c), kColors[color++ % 6]});
    if (p.column("train_violations") >= 0)
      train.push_back({"violations (steps)", col("train_violations"), "#7f7f7f"});
    if (!train.empty())
      panels.push_back(panel("training: collisions and violations (running total)", "count", steps, train));
    // Evaluation: per episode.
    std::vector<Curve> eval;
    color = 0;
    for (const std::string& c : p.columns())
      if (c.size() >= 9 && c.compare(c.size() - 9, 9, "collision") == 0 && c.rfind("train_", 0) != 0)
        eval.push_back({c + "s", col(c), kColors[color++ % 6]});
    if (p.column("violations") >= 0) eval.push_back({"violations (steps)", col("violations"), "#7f7f7f"});
    if (!eval.empty())
      panels.push_back(panel("evaluation: collisions and violations per episode", "per episode", steps, eval));
  }

  const int cols = panels.size() > 1 ? 2 : 1, rows = int((panels.size() + 1) / 2);
  const double W = cols * kPanelW, H = 36 + rows * kPanelH;
  std::string out = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(int(W)) + "\" height=\"" +
                    std::to_string(int(H)) + "\" viewBox=\"0 0 " + std::to_string(int(W)) + " " +
                    std::to_string(int(H)) + "\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n" +
                    "<text x=\"" + std::to_string(int(W / 2)) + "\" y=\"24\" font-family=\"sans-serif\" " +
                    "font-size=\"16\" text-anchor=\"middle\" fill=\"#222\">" + svg_escape(title) + "</text>\n";
  for (size_t i = 0; i < panels.size(); ++i) {
    // Nested <svg> at the panel's place in the grid.
    const std::string at = "<svg x=\"" + std::to_string(int((i % 2) * kPanelW)) + "\" y=\"" +
                           std::to_string(int(36 + (i / 2) * kPanelH)) + "\" ";
    std::string s = panels[i];
    s.replace(0, 5, at);
    out += s;
  }
  return out + "</svg>\n";
}

}  // namespace atacom
