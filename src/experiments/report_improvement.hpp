// P(improvement) in the sweep report: which pairs prob_improvement.csv
// holds, and one pair's number with its bootstrap interval, computed the
// same way wherever the report needs it (the tables, the paper's claims).
// Internal to src/experiments/.
#pragma once
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "src/experiments/report_data.hpp"
#include "src/experiments/report_stats.hpp"

namespace atacom {

// The algorithm whose improvement on each baseline is reported: ATACOM-SAC
// (the paper's), or ATACOM-PPO in a sweep without it; "" when neither ran.
std::string main_algorithm(const ReportData& d);

// The pairs (algo, baseline) of prob_improvement.csv: the main algorithm
// against every other one, then every other source through ATACOM against
// the same source without a layer when both ran (the paper's "ATACOM
// improves LA": la-atacom vs la).
std::vector<std::pair<std::string, std::string>> improvement_pairs(const ReportData& d);

struct Improvement {
  size_t n_algo = 0, n_baseline = 0;  // finished runs with a value
  double p = NAN;                     // NaN below kMinSeedsForInterval runs on either side
  Interval ci{NAN, NAN};              // 95 % bootstrap interval of p
};

// P(algo improves on baseline) on metric m in env. A pair of
// improvement_pairs has the numbers of prob_improvement.csv; its reverse
// (baseline improves on algo) is 1 - P with the interval mirrored, the
// same resamples; any other pair has a bootstrap stream of its own.
Improvement improvement(const ReportData& d, const std::string& env, const ReportMetric& m, const std::string& algo,
                        const std::string& baseline);

}  // namespace atacom
