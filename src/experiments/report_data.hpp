// The runs of a sweep as the report reads them (internal to src/experiments/).
#pragma once
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/experiments/report.hpp"
#include "src/experiments/sweep_spec.hpp"

namespace atacom {

class SvgCanvas;

struct ReportRun {
  SweepCell cell;
  std::string state, log;      // sweep state (done, failed, ...) and log path
  bool finished = false;       // summary.json covering the spec's steps
  nlohmann::json summary;      // null unless finished
  std::vector<double> steps, eval_return, final_distance;  // progress.csv curves (empty when absent)
  std::vector<double> train_cost;  // progress.csv's train_cost per row (empty: a run of a build before it)
};

struct ReportData {
  ReportOptions opts;
  std::vector<std::string> envs, algos;  // spec order
  std::vector<ReportRun> runs;           // sweep_cells order
};

ReportData load_report_data(const ReportOptions& opts);
// A metric's value in a run's summary ("best.<key>" looks in "best"); nullopt when absent or not finite.
std::optional<double> metric_value(const nlohmann::json& summary, const std::string& key);
const ReportMetric* find_report_metric(const std::string& key);  // nullptr: not a report metric
// A censored metric's value: metric_value, or +inf when the run's env has a
// quality target and the key is null (never met); nullopt when not applicable.
std::optional<double> censored_value(const nlohmann::json& summary, const std::string& key);
// Values of the finished runs of (env, algo), in seed order (a censored
// metric's runs that never met the target as +inf).
std::vector<double> metric_values(const ReportData& d, const std::string& env, const std::string& algo,
                                  const std::string& key);

// Figures, one file each (the colours: train/algorithms.hpp, algorithm_color).
std::string boxplot_svg(const ReportData& d, const std::string& env);         // the boxplot metrics
std::string target_boxplot_svg(const ReportData& d, const std::string& env);  // the censored metrics
std::string curves_svg(const ReportData& d, const std::string& env);
// cost_return_<env>.svg: final return against the final policy's episode
// cost and against the run's training cost, a point per seed and the IQM of
// both coordinates per algorithm (src/experiments/report_cost_figures.cpp).
std::string cost_return_svg(const ReportData& d, const std::string& env);
// train_cost_<env>.svg: cumulative training cost against env steps, IQM over
// seeds with a bootstrap band, for every algorithm that trains.
std::string train_cost_svg(const ReportData& d, const std::string& env);

// Shared pieces of the figures (report_figures.cpp).
std::string svg_placed(const SvgCanvas& c, double x, double y);  // a canvas at (x, y) inside a bigger SVG
std::string svg_figure(double w, double h, const std::string& title, const std::vector<std::string>& algos,
                       const std::vector<bool>& dashed, const std::string& body);  // title, legend, body
void pad_range(double& lo, double& hi);  // 6 % padding, at least a billionth of the magnitude wide

}  // namespace atacom
