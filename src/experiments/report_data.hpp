// The runs of a sweep as the report reads them (internal to src/experiments/).
#pragma once
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/experiments/report.hpp"
#include "src/experiments/sweep_spec.hpp"

namespace atacom {

struct ReportRun {
  SweepCell cell;
  std::string state, log;      // sweep state (done, failed, ...) and log path
  bool finished = false;       // summary.json covering the spec's steps
  nlohmann::json summary;      // null unless finished
  std::vector<double> steps, eval_return, final_distance;  // progress.csv curves (empty when absent)
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

std::string algo_color(size_t algo_index);
std::string boxplot_svg(const ReportData& d, const std::string& env);         // the boxplot metrics
std::string target_boxplot_svg(const ReportData& d, const std::string& env);  // the censored metrics
std::string curves_svg(const ReportData& d, const std::string& env);

}  // namespace atacom
