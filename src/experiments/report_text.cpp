#include "src/experiments/report_text.hpp"

#include <cmath>
#include <cstdio>
#include <string_view>

#include "src/core/config_json.hpp"
#include "src/core/svg.hpp"

namespace atacom {

std::string no_stat(size_t n, const char* what) { return "n = " + std::to_string(n) + ": no " + what; }

std::string num(double v) {
  if (std::isnan(v)) return "nan";
  char b[40];
  std::snprintf(b, sizeof(b), "%.12g", v);
  return b;
}
std::string num_or_empty(double v) {
  if (std::isnan(v)) return "";
  char b[40];
  std::snprintf(b, sizeof(b), "%.12g", v);
  return b;
}
std::string short_num(double v) {
  if (std::isnan(v)) return "-";
  char b[40];
  std::snprintf(b, sizeof(b), "%.4g", v);
  return b;
}
std::string target_num(double v) { return std::isinf(v) && v > 0 ? "not reached" : short_num(v); }
std::string html_escape(const std::string& s) { return svg_escape(printable_text(s, 4096)); }
std::string markdown_text(const std::string& s) {
  std::string out;
  for (char c : printable_text(s, 4096)) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (std::string_view("\\`*_{}[]()#+-.!|~\"'").find(c) != std::string_view::npos) out += std::string("\\") + c;
    else out += c;
  }
  return out;
}

}  // namespace atacom
