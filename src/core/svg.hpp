// A small SVG writer for the pictures runs leave behind (trajectories,
// learning curves). Coordinates are given in data units and mapped into the
// plot area; y points up.
#pragma once
#include <string>
#include <utility>
#include <vector>

namespace atacom {

class SvgCanvas {
 public:
  // Plot area of width x height pixels showing [x0, x1] x [y0, y1], with a margin for axes.
  SvgCanvas(double width, double height, double x0, double x1, double y0, double y1, double margin = 40);

  void line(double xa, double ya, double xb, double yb, const std::string& color, double stroke = 1.0,
            const std::string& dash = "");
  void polyline(const std::vector<std::pair<double, double>>& pts, const std::string& color, double stroke = 1.5,
                double opacity = 1.0);
  void circle(double x, double y, double r_data, const std::string& fill, const std::string& stroke = "none",
              double opacity = 1.0);
  // A filled polygon (bands).
  void polygon(const std::vector<std::pair<double, double>>& pts, const std::string& fill, double opacity = 0.25);
  void rect(double xa, double ya, double xb, double yb, const std::string& fill, const std::string& stroke = "none");
  // Text at data coordinates (anchor: start | middle | end).
  void text(double x, double y, const std::string& s, double size = 12, const std::string& anchor = "start",
            const std::string& color = "#222");
  // Text at pixel coordinates of the whole image.
  void label(double px, double py, const std::string& s, double size = 12, const std::string& anchor = "start",
             const std::string& color = "#222", bool rotate = false);
  // Axes with ticks along the plot area's left and bottom edges: about
  // xticks / yticks round values (steps 1, 2 or 5 x 10^k), labelled alike
  // along each axis (format_ticks).
  void axes(const std::string& xlabel, const std::string& ylabel, int xticks = 5, int yticks = 5);
  // The left axis alone (for category plots, which label x themselves).
  void y_axis(const std::string& ylabel, int yticks = 5);
  // The bottom axis alone (for plots with their own y ticks, e.g. a log scale).
  void x_axis(const std::string& xlabel, int xticks = 5);

  std::string str() const;
  // Atomic write (temp file + rename); throws std::runtime_error on failure.
  void save(const std::string& path) const;

  double px(double x) const;
  double py(double y) const;

 private:
  void x_ticks(int xticks);  // the bottom line, grid and tick labels
  double w_, h_, x0_, x1_, y0_, y1_, m_;
  std::string body_;
};

// Nice-looking tick value formatting (trims zeros, uses k/M suffixes for large values).
std::string format_tick(double v);
// Round tick values inside [lo, hi], about `target` of them: multiples of 1, 2 or 5 x 10^k.
std::vector<double> nice_ticks(double lo, double hi, int target);
// Labels for the ticks of one axis, formatted alike: one unit for all (k or
// M from the largest magnitude) and the same number of decimals
// ("0, 4k, 8k, 12k", never "4000, 8000, 12k").
std::vector<std::string> format_ticks(const std::vector<double>& ticks);
// XML-escape a string for SVG text.
std::string svg_escape(const std::string& s);

}  // namespace atacom
