#include "src/core/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <tuple>

#include "src/core/fs_util.hpp"

namespace atacom {

namespace {
// Pixel coordinates: always a finite number in the file (a value far outside
// the plot lands far outside the picture, never as "nan" or "inf").
std::string svg_num(double v) {
  char buf[32];
  if (!(v == v)) v = 0;
  std::snprintf(buf, sizeof(buf), "%.2f", std::clamp(v, -1e7, 1e7));
  return buf;
}
}  // namespace

std::string svg_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string format_tick(double v) {
  char buf[32];
  const double a = std::abs(v);
  if (a >= 1e6) std::snprintf(buf, sizeof(buf), "%gM", v / 1e6);
  else if (a >= 1e4) std::snprintf(buf, sizeof(buf), "%gk", v / 1e3);
  else std::snprintf(buf, sizeof(buf), "%g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

namespace {
// A data range to map: finite and of positive width (else [lo, lo + 1], or [0, 1]).
std::pair<double, double> usable_range(double lo, double hi) {
  if (!std::isfinite(lo)) lo = std::isfinite(hi) ? hi - 1 : 0;
  if (!std::isfinite(hi) || !(hi > lo)) hi = std::nextafter(lo, INFINITY) > lo + 1 ? std::nextafter(lo, INFINITY) : lo + 1;
  return {lo, hi};
}
}  // namespace

SvgCanvas::SvgCanvas(double width, double height, double x0, double x1, double y0, double y1, double margin)
    : w_(width), h_(height), m_(margin) {
  std::tie(x0_, x1_) = usable_range(x0, x1);
  std::tie(y0_, y1_) = usable_range(y0, y1);
}

// In long double: the width of [-1e308, 1e308] does not overflow.
double SvgCanvas::px(double x) const {
  return double(m_ + ((long double)x - x0_) / ((long double)x1_ - x0_) * (w_ - 2 * m_));
}
double SvgCanvas::py(double y) const {
  return double(h_ - m_ - ((long double)y - y0_) / ((long double)y1_ - y0_) * (h_ - 2 * m_));
}

void SvgCanvas::line(double xa, double ya, double xb, double yb, const std::string& color, double stroke,
                     const std::string& dash) {
  body_ += "<line x1=\"" + svg_num(px(xa)) + "\" y1=\"" + svg_num(py(ya)) + "\" x2=\"" + svg_num(px(xb)) + "\" y2=\"" +
           svg_num(py(yb)) + "\" stroke=\"" + color + "\" stroke-width=\"" + svg_num(stroke) + "\"" +
           (dash.empty() ? "" : " stroke-dasharray=\"" + dash + "\"") + "/>\n";
}

void SvgCanvas::polyline(const std::vector<std::pair<double, double>>& pts, const std::string& color, double stroke,
                         double opacity) {
  if (pts.empty()) return;
  std::string p;
  for (const auto& [x, y] : pts) p += svg_num(px(x)) + "," + svg_num(py(y)) + " ";
  body_ += "<polyline fill=\"none\" stroke=\"" + color + "\" stroke-width=\"" + svg_num(stroke) + "\" stroke-opacity=\"" +
           svg_num(opacity) + "\" points=\"" + p + "\"/>\n";
}

void SvgCanvas::circle(double x, double y, double r_data, const std::string& fill, const std::string& stroke,
                       double opacity) {
  const double r = double((long double)r_data / ((long double)x1_ - x0_) * (w_ - 2 * m_));
  body_ += "<circle cx=\"" + svg_num(px(x)) + "\" cy=\"" + svg_num(py(y)) + "\" r=\"" + svg_num(r) + "\" fill=\"" + fill +
           "\" stroke=\"" + stroke + "\" fill-opacity=\"" + svg_num(opacity) + "\"/>\n";
}

void SvgCanvas::polygon(const std::vector<std::pair<double, double>>& pts, const std::string& fill, double opacity) {
  if (pts.empty()) return;
  std::string p;
  for (const auto& [x, y] : pts) p += svg_num(px(x)) + "," + svg_num(py(y)) + " ";
  body_ += "<polygon fill=\"" + fill + "\" fill-opacity=\"" + svg_num(opacity) + "\" stroke=\"none\" points=\"" + p + "\"/>\n";
}

void SvgCanvas::rect(double xa, double ya, double xb, double yb, const std::string& fill, const std::string& stroke) {
  const double l = std::min(px(xa), px(xb)), t = std::min(py(ya), py(yb));
  body_ += "<rect x=\"" + svg_num(l) + "\" y=\"" + svg_num(t) + "\" width=\"" + svg_num(std::abs(px(xb) - px(xa))) +
           "\" height=\"" + svg_num(std::abs(py(yb) - py(ya))) + "\" fill=\"" + fill + "\" stroke=\"" + stroke + "\"/>\n";
}

void SvgCanvas::text(double x, double y, const std::string& s, double size, const std::string& anchor,
                     const std::string& color) {
  label(px(x), py(y), s, size, anchor, color);
}

void SvgCanvas::label(double x, double y, const std::string& s, double size, const std::string& anchor,
                      const std::string& color, bool rotate) {
  body_ += "<text x=\"" + svg_num(x) + "\" y=\"" + svg_num(y) + "\" font-family=\"sans-serif\" font-size=\"" + svg_num(size) +
           "\" text-anchor=\"" + anchor + "\" fill=\"" + color + "\"" +
           (rotate ? " transform=\"rotate(-90 " + svg_num(x) + " " + svg_num(y) + ")\"" : "") + ">" + svg_escape(s) +
           "</text>\n";
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo)) return {std::isfinite(lo) ? lo : 0.0};
  target = std::clamp(target, 1, 50);
  // long double: hi - lo of [-1e308, 1e308] does not overflow.
  const long double raw = ((long double)hi - lo) / target;
  const long double mag = std::pow(10.0L, std::floor(std::log10(raw)));
  long double step = mag;
  for (long double m : {1.0L, 2.0L, 5.0L, 10.0L})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  // Ticks k * step for the integers k in [k0, k1]. A counter, not a double
  // stepped by 1 (above 2^53 that never moves on); a step below the values'
  // resolution (500 vs 499.99999999999994) gives the ends only.
  const long double k0 = std::ceil(lo / step - 1e-9L), k1 = std::floor(hi / step + 1e-9L);
  constexpr long double kMaxTicks = 1000;
  if (!(k1 - k0 < kMaxTicks) || std::abs(k0) > 0x1p52L || std::abs(k1) > 0x1p52L) return {lo, hi};
  std::vector<double> out;
  for (long long i = 0; i <= (long long)(k1 - k0); ++i) {
    long double v = (k0 + i) * step;
    if (std::abs(v) < step * 1e-9L) v = 0;
    if (out.empty() || double(v) != out.back()) out.push_back(double(v));
  }
  if (out.empty()) out.push_back(lo);
  return out;
}

std::vector<std::string> format_ticks(const std::vector<double>& ticks) {
  double big = 0;
  for (double v : ticks) big = std::max(big, std::abs(v));
  const double unit = big >= 1e6 ? 1e6 : big >= 1e4 ? 1e3 : 1.0;
  const char* suffix = unit == 1e6 ? "M" : unit == 1e3 ? "k" : "";
  int decimals = 0;
  for (; decimals < 6; ++decimals) {
    const double p = std::pow(10.0, decimals);
    bool exact = true;
    for (double v : ticks) {
      const double x = v / unit * p;
      exact = exact && std::abs(x - std::round(x)) < 1e-6 * std::max(1.0, std::abs(x));
    }
    if (exact) break;
  }
  std::vector<std::string> out;
  for (double v : ticks) {
    char buf[48];
    const double x = v / unit;
    std::snprintf(buf, sizeof(buf), "%.*f%s", decimals, std::abs(x) < 1e-12 ? 0.0 : x, x == 0 ? "" : suffix);
    out.push_back(buf);
  }
  return out;
}

void SvgCanvas::y_axis(const std::string& ylabel, int yticks) {
  line(x0_, y0_, x0_, y1_, "#444");
  const std::vector<double> ty = nice_ticks(y0_, y1_, yticks);
  const std::vector<std::string> ly = format_ticks(ty);
  for (size_t i = 0; i < ty.size(); ++i) {
    line(x0_, ty[i], x1_, ty[i], "#ddd", 0.5);
    label(px(x0_) - 4, py(ty[i]) + 3, ly[i], 10, "end");
  }
  label(12, (py(y0_) + py(y1_)) / 2, ylabel, 12, "middle", "#222", true);
}

void SvgCanvas::x_ticks(int xticks) {
  line(x0_, y0_, x1_, y0_, "#444");
  const std::vector<double> tx = nice_ticks(x0_, x1_, xticks);
  const std::vector<std::string> lx = format_ticks(tx);
  for (size_t i = 0; i < tx.size(); ++i) {
    line(tx[i], y0_, tx[i], y1_, "#ddd", 0.5);
    label(px(tx[i]), py(y0_) + 14, lx[i], 10, "middle");
  }
}

void SvgCanvas::axes(const std::string& xlabel, const std::string& ylabel, int xticks, int yticks) {
  x_ticks(xticks);
  y_axis(ylabel, yticks);
  label((px(x0_) + px(x1_)) / 2, h_ - 6, xlabel, 12, "middle");
}

void SvgCanvas::x_axis(const std::string& xlabel, int xticks) {
  x_ticks(xticks);
  label((px(x0_) + px(x1_)) / 2, h_ - 6, xlabel, 12, "middle");
}

std::string SvgCanvas::str() const {
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w_ << "\" height=\"" << h_ << "\" viewBox=\"0 0 " << w_
    << " " << h_ << "\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    << body_ << "</svg>\n";
  return o.str();
}

void SvgCanvas::save(const std::string& path) const { write_file_atomic(path, str()); }

}  // namespace atacom
