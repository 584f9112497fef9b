// atacom report DIR: the statistics and figures of a sweep directory
// (src/experiments/sweep_state.hpp), written to DIR/report/:
//   summary.csv           env, algo, metric, n, mean, std, median, q1, q3, iqm, iqm_ci_low, iqm_ci_high
//                         (metric = the summary.json key; "best.<key>" for the best evaluation)
//   time_to_target.csv    env, algo, metric, n, reached, median, q1, q3, iqm, iqm_ci_low, iqm_ci_high for
//                         the censored metrics (time_to_target_s, ...; "inf": not reached, see below)
//   prob_improvement.csv  env, metric, algo, baseline, n_algo, n_baseline, p_improvement (ATACOM-SAC vs each,
//                         then each other source through ATACOM vs the same source without: la-atacom vs la)
//   final_vs_best.csv     per run: final and best evaluation side by side, drop = 1 when the final one fell far
//   missing.csv           cells without a finished run: state and log
//   claims.csv            (sweeps with a claim's cells) the paper's claims, one row per check: the numbers
//                         and a verdict (src/experiments/report_claims.hpp); summary.md and index.html
//                         open with them
//   shelf_real.csv        (sweeps with shelf runs) every finished shelf policy through the ShelfEnvReal
//                         protocol: algo, seed, safety, target, success_rate, final_error_mean, ...
//                         (src/experiments/report_shelf_real.hpp); skipped runs with their reason
//   summary.md            all of it as tables
//   box_<env>.svg         one panel per metric, one box per algo, a point per seed
//   target_<env>.svg      the same for the censored metrics (envs with a quality target), runs that
//                         never met it drawn on a "not reached" line, "reached k/n" under each box
//   curves_<env>.svg      eval return and final distance vs env steps: IQM over seeds, bootstrap band
//   cost_return_<env>.svg final return vs the final policy's episode cost and vs the training cost:
//                         a point per seed, an IQM diamond per algorithm
//   train_cost_<env>.svg  cumulative training cost vs env steps: IQM over seeds, bootstrap band
//   index.html            figures and tables in one page (inline SVG: opens from file://, no network)
// Statistics: src/experiments/report_stats.hpp.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace atacom {

struct ReportMetric {
  const char* key;     // summary.json key ("best.final_distance": key of the best evaluation)
  const char* label;
  bool higher_better;
  bool boxplot;        // a panel of the boxplot grid
  // Right-censored (time_to_target_s and its kin): null in a run whose env has
  // a quality target ("target" in summary.json) that the run never met. Such a
  // run counts as +inf (later than every run that met it), never dropped; its
  // own table (time_to_target.csv, "reached k/n") and figure (target_<env>.svg).
  bool censored = false;
};
const std::vector<ReportMetric>& report_metrics();

struct ReportOptions {
  std::string dir;              // the sweep directory
  int resamples = 2000;         // bootstrap resamples of the tables' intervals
  int curve_resamples = 500;    // of the learning-curve bands (one interval per evaluation)
  uint64_t seed = 0;            // bootstrap seed
  // A run's final evaluation "fell far below its best" when its return is
  // below best - drop_return_frac * max(|best|, best - first evaluation's
  // return), or its final distance above the best evaluation's by more than
  // drop_distance (metres).
  double drop_return_frac = 0.1;
  double drop_distance = 0.2;
  // Only these seeds' cells (ascending, no repeats; empty: every cell), e.g.
  // the seeds a sweep has completed while it runs on; the report then goes
  // to DIR/report-seeds-<list> (report_dir_name).
  std::vector<int64_t> seeds;
  // The paper's claims to check (src/experiments/report_claims.hpp): a
  // claims file; empty: the shipped data/paper_claims.json; "none": none.
  std::string claims;
};
// Parses "0-4", "0,2,5" or "0-4,9" into the ascending seeds (no repeats; at
// most 100000). Throws std::invalid_argument naming --seeds otherwise.
std::vector<int64_t> parse_seed_list(const std::string& text);
// Ascending seeds as the shortest such list: {0, 1, 2, 7} -> "0-2,7".
std::string seed_list_text(const std::vector<int64_t>& seeds);
// The directory name of a report: "report", or "report-seeds-0-2_7" (the
// list with '_' for ','), from opts.seeds.
std::string report_dir_name(const ReportOptions& opts);

struct ReportResult {
  std::string report_dir, index_html;
  int runs = 0, finished = 0;
  std::vector<std::string> missing;  // cell names without a finished run
  std::vector<std::string> dropped;  // runs whose final evaluation fell far below their best
  bool claims = false;               // claims.csv written: the sweep holds a claim's cells
};

// Throws std::invalid_argument when DIR is not a sweep directory, or holds no finished run.
ReportResult write_report(const ReportOptions& opts);

}  // namespace atacom
