#include "train/run_files.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "atacom/trainer.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/svg.hpp"

namespace atacom {

// ---------------------------------------------------------------- progress.csv
std::vector<std::string> progress_columns(const EnvSpec& spec, const std::vector<std::string>& learner_columns) {
  std::vector<std::string> cols = {"env_steps", "updates", "wall_s", "eval_return_mean", "eval_return_std",
                                   "train_episode_return"};
  cols.insert(cols.end(), learner_columns.begin(), learner_columns.end());
  cols.insert(cols.end(), spec.info_names.begin(), spec.info_names.end());
  for (const char* c : {"early_terminations", "avg_episode_steps", "violations", "eval_cost_mean",
                        "eval_discounted_return_mean", "eval_discounted_return_std", "eval_max_constraint",
                        "eval_episode_max_constraint", "train_episodes", "train_terminations", "train_violations",
                        "train_cost"})
    cols.push_back(c);
  for (size_t c = 0; c < spec.info_names.size() && c < spec.info_reduce.size(); ++c)
    if (spec.info_reduce[c] == InfoReduce::Sum) cols.push_back("train_" + spec.info_names[c]);
  cols.insert(cols.end(), target_columns().begin(), target_columns().end());
  return cols;
}

const std::vector<std::string>& target_columns() {
  static const std::vector<std::string> c = {"time_to_target_s", "steps_to_target", "updates_to_target",
                                             "train_cost_to_target"};
  return c;
}

ProgressFile::ProgressFile(std::string path, std::vector<std::string> columns, const std::vector<std::string>& blank_nan)
    : path_(std::move(path)), columns_(std::move(columns)), blank_nan_(columns_.size(), 0) {
  for (size_t k = 0; k < columns_.size(); ++k) {
    if (!header_.empty()) header_ += ',';
    header_ += columns_[k];
    for (const std::string& b : blank_nan) blank_nan_[k] = blank_nan_[k] || b == columns_[k];
  }
}

std::string ProgressFile::format(double v) {
  if (!std::isfinite(v)) return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
  char b[40];
  std::snprintf(b, sizeof(b), "%.9g", v);
  return b;
}

int ProgressFile::column(const std::string& name) const {
  for (size_t c = 0; c < columns_.size(); ++c)
    if (columns_[c] == name) return int(c);
  return -1;
}

std::vector<double> ProgressFile::series(int col) const {
  std::vector<double> s;
  for (const auto& row : values_) s.push_back(col >= 0 && size_t(col) < row.size() ? row[size_t(col)] : NAN);
  return s;
}

void ProgressFile::write() const {
  std::string text = header_ + "\n";
  for (const std::string& l : lines_) text += l + "\n";
  write_file_atomic(path_, text);
}

void ProgressFile::start() {
  lines_.clear();
  values_.clear();
  write();
}

void ProgressFile::append(const std::vector<double>& row) {
  if (row.size() != columns_.size())
    throw std::logic_error("progress row has " + std::to_string(row.size()) + " values for " +
                           std::to_string(columns_.size()) + " columns");
  std::string line;
  for (size_t k = 0; k < row.size(); ++k) {
    if (k) line += ',';
    if (!(blank_nan_[k] && std::isnan(row[k]))) line += format(row[k]);
  }
  lines_.push_back(line);
  values_.push_back(row);
  write();
}

void ProgressFile::restore(int64_t rows) {
  std::ifstream f(path_, std::ios::binary);
  if (!f) throw std::runtime_error("'" + path_ + "' is missing; the checkpoint expects " + std::to_string(rows) +
                                   " evaluation rows in it");
  std::string line;
  if (!std::getline(f, line))
    throw std::runtime_error("'" + path_ + "' does not start with this run's header (" + header_.substr(0, 60) + "...)");
  // The file's columns: col_of[k] = this run's column of file column k (a
  // header of an earlier build may lack columns added since).
  const bool same_header = line == header_;
  std::vector<int> col_of;
  if (same_header) {
    for (size_t c = 0; c < columns_.size(); ++c) col_of.push_back(int(c));
  } else {
    std::istringstream hs(line);
    for (std::string name; std::getline(hs, name, ',');) {
      const int c = column(name);
      if (c < 0 || std::find(col_of.begin(), col_of.end(), c) != col_of.end())
        throw std::runtime_error("'" + path_ + "' does not start with this run's header (" + header_.substr(0, 60) +
                                 "...): its column '" + name + "' is not one of this run's");
      col_of.push_back(c);
    }
  }
  lines_.clear();
  values_.clear();
  while (int64_t(lines_.size()) < rows && std::getline(f, line)) {
    std::vector<double> cells;
    std::vector<std::string> texts;
    std::istringstream ls(line);
    std::string cell;
    // getline drops an empty last cell: the line's cells are its commas + 1.
    const size_t n = size_t(std::count(line.begin(), line.end(), ',')) + 1;
    while (cells.size() < n) {
      if (!std::getline(ls, cell, ',')) cell.clear();
      const size_t k = cells.size();
      texts.push_back(cell);
      if (cell.empty() && k < col_of.size() && blank_nan_[size_t(col_of[k])]) {
        cells.push_back(NAN);
        continue;
      }
      char* end = nullptr;
      const double x = std::strtod(cell.c_str(), &end);
      if (cell.empty() || end != cell.c_str() + cell.size())
        throw std::runtime_error("'" + path_ + "' row " + std::to_string(lines_.size() + 1) + " holds '" + cell +
                                 "', not a number");
      cells.push_back(x);
    }
    if (cells.size() != col_of.size())
      throw std::runtime_error("'" + path_ + "' row " + std::to_string(lines_.size() + 1) + " has " +
                               std::to_string(cells.size()) + " values for " + std::to_string(col_of.size()) +
                               " columns");
    if (same_header) {
      lines_.push_back(line);
      values_.push_back(cells);
      continue;
    }
    // Columns the file lacks: NaN ("nan", or an empty cell where NaN is written so).
    std::vector<double> v(columns_.size(), std::numeric_limits<double>::quiet_NaN());
    std::vector<const std::string*> text(columns_.size(), nullptr);
    for (size_t k = 0; k < col_of.size(); ++k) {
      v[size_t(col_of[k])] = cells[k];
      text[size_t(col_of[k])] = &texts[k];
    }
    std::string out;
    for (size_t c = 0; c < columns_.size(); ++c) {
      if (c) out += ',';
      if (text[c]) out += *text[c];
      else if (!blank_nan_[c]) out += "nan";
    }
    lines_.push_back(out);
    values_.push_back(v);
  }
  if (int64_t(lines_.size()) < rows)
    throw std::runtime_error("'" + path_ + "' holds " + std::to_string(lines_.size()) +
                             " evaluation rows, the checkpoint expects " + std::to_string(rows));
  write();  // rows after the checkpoint are dropped; the file is replaced, not written through
}

// ---------------------------------------------------------------- progress.svg
std::string learning_curve_svg(const std::string& title, const std::vector<double>& steps,
                               const std::vector<double>& mean, const std::vector<double>& sd) {
  double x1 = 1, y0 = 0, y1 = 1;
  bool any = false;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (!std::isfinite(mean[i])) continue;
    const double s = std::isfinite(sd[i]) ? sd[i] : 0.0;
    if (!any) { y0 = mean[i] - s; y1 = mean[i] + s; any = true; }
    x1 = std::max(x1, steps[i]);
    y0 = std::min(y0, mean[i] - s);
    y1 = std::max(y1, mean[i] + s);
  }
  if (y1 - y0 < 1e-9) { y0 -= 1; y1 += 1; }
  // round the y range out to ticks at multiples of 1, 2 or 5 x 10^k
  const double raw = (y1 - y0) / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw <= mag ? mag : raw <= 2 * mag ? 2 * mag : raw <= 5 * mag ? 5 * mag : 10 * mag;
  const double lo = std::floor(y0 / step) * step;
  const int yticks = std::max(1, static_cast<int>(std::ceil((y1 - lo) / step - 1e-9)));
  SvgCanvas svg(640, 400, 0.0, x1, lo, lo + yticks * step, 64);
  svg.axes("env steps", "eval return (mean, mean +- std)", 5, yticks);
  svg.label(320, 24, title, 15, "middle");
  std::vector<std::pair<double, double>> line, up, down;
  for (size_t i = 0; i < steps.size(); ++i) {
    if (!std::isfinite(mean[i])) continue;
    const double s = std::isfinite(sd[i]) ? sd[i] : 0.0;
    line.emplace_back(steps[i], mean[i]);
    up.emplace_back(steps[i], mean[i] + s);
    down.emplace_back(steps[i], mean[i] - s);
  }
  if (!line.empty()) {
    svg.polyline(up, "#1f77b4", 1.0, 0.35);
    svg.polyline(down, "#1f77b4", 1.0, 0.35);
    svg.polyline(line, "#1f77b4", 2.0);
    for (const auto& [x, y] : line) svg.circle(x, y, 0.006 * x1, "#1f77b4");  // one dot per evaluation
  }
  return svg.str();
}

}  // namespace atacom
