#include "src/core/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "src/core/fs_util.hpp"

namespace atacom {

namespace {
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f", v);
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

SvgCanvas::SvgCanvas(double width, double height, double x0, double x1, double y0, double y1, double margin)
    : w_(width), h_(height), x0_(x0), x1_(x1 > x0 ? x1 : x0 + 1), y0_(y0), y1_(y1 > y0 ? y1 : y0 + 1), m_(margin) {}

double SvgCanvas::px(double x) const { return m_ + (x - x0_) / (x1_ - x0_) * (w_ - 2 * m_); }
double SvgCanvas::py(double y) const { return h_ - m_ - (y - y0_) / (y1_ - y0_) * (h_ - 2 * m_); }

void SvgCanvas::line(double xa, double ya, double xb, double yb, const std::string& color, double stroke,
                     const std::string& dash) {
  body_ += "<line x1=\"" + num(px(xa)) + "\" y1=\"" + num(py(ya)) + "\" x2=\"" + num(px(xb)) + "\" y2=\"" +
           num(py(yb)) + "\" stroke=\"" + color + "\" stroke-width=\"" + num(stroke) + "\"" +
           (dash.empty() ? "" : " stroke-dasharray=\"" + dash + "\"") + "/>\n";
}

void SvgCanvas::polyline(const std::vector<std::pair<double, double>>& pts, const std::string& color, double stroke,
                         double opacity) {
  if (pts.empty()) return;
  std::string p;
  for (const auto& [x, y] : pts) p += num(px(x)) + "," + num(py(y)) + " ";
  body_ += "<polyline fill=\"none\" stroke=\"" + color + "\" stroke-width=\"" + num(stroke) + "\" stroke-opacity=\"" +
           num(opacity) + "\" points=\"" + p + "\"/>\n";
}

void SvgCanvas::circle(double x, double y, double r_data, const std::string& fill, const std::string& stroke,
                       double opacity) {
  const double r = r_data / (x1_ - x0_) * (w_ - 2 * m_);
  body_ += "<circle cx=\"" + num(px(x)) + "\" cy=\"" + num(py(y)) + "\" r=\"" + num(r) + "\" fill=\"" + fill +
           "\" stroke=\"" + stroke + "\" fill-opacity=\"" + num(opacity) + "\"/>\n";
}

void SvgCanvas::rect(double xa, double ya, double xb, double yb, const std::string& fill, const std::string& stroke) {
  const double l = std::min(px(xa), px(xb)), t = std::min(py(ya), py(yb));
  body_ += "<rect x=\"" + num(l) + "\" y=\"" + num(t) + "\" width=\"" + num(std::abs(px(xb) - px(xa))) +
           "\" height=\"" + num(std::abs(py(yb) - py(ya))) + "\" fill=\"" + fill + "\" stroke=\"" + stroke + "\"/>\n";
}

void SvgCanvas::text(double x, double y, const std::string& s, double size, const std::string& anchor,
                     const std::string& color) {
  label(px(x), py(y), s, size, anchor, color);
}

void SvgCanvas::label(double x, double y, const std::string& s, double size, const std::string& anchor,
                      const std::string& color, bool rotate) {
  body_ += "<text x=\"" + num(x) + "\" y=\"" + num(y) + "\" font-family=\"sans-serif\" font-size=\"" + num(size) +
           "\" text-anchor=\"" + anchor + "\" fill=\"" + color + "\"" +
           (rotate ? " transform=\"rotate(-90 " + num(x) + " " + num(y) + ")\"" : "") + ">" + svg_escape(s) +
           "</text>\n";
}

void SvgCanvas::axes(const std::string& xlabel, const std::string& ylabel, int xticks, int yticks) {
  line(x0_, y0_, x1_, y0_, "#444");
  line(x0_, y0_, x0_, y1_, "#444");
  for (int i = 0; i <= xticks; ++i) {
    const double x = x0_ + (x1_ - x0_) * i / xticks;
    line(x, y0_, x, y1_, "#ddd", 0.5);
    label(px(x), py(y0_) + 14, format_tick(x), 10, "middle");
  }
  for (int i = 0; i <= yticks; ++i) {
    const double y = y0_ + (y1_ - y0_) * i / yticks;
    line(x0_, y, x1_, y, "#ddd", 0.5);
    label(px(x0_) - 4, py(y) + 3, format_tick(y), 10, "end");
  }
  label((px(x0_) + px(x1_)) / 2, h_ - 6, xlabel, 12, "middle");
  label(12, (py(y0_) + py(y1_)) / 2, ylabel, 12, "middle", "#222", true);
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
