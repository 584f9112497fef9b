// Statistics of the sweep report, with rliable's definitions (Agarwal et
// al., NeurIPS 2021):
//   quantile   linear interpolation between order statistics (numpy's default,
//              Hyndman-Fan type 7)
//   std        sample standard deviation (n - 1)
//   IQM        the 25 %-trimmed mean: sort, drop floor(n / 4) values at each
//              end, average the rest (scipy.stats.trim_mean(x, 0.25))
//   CI         percentile bootstrap: `resamples` resamples of the n seeds with
//              replacement (one task per (env, algo) cell, so stratifying by
//              task is resampling within the cell), the statistic of each, and
//              the 2.5 % / 97.5 % quantiles of those; seeded, so a report is
//              reproducible bit for bit
//   P(X > Y)   probability of improvement, Mann-Whitney form: over all pairs
//              (x_i, y_j), 1 when x_i is better, 1/2 when equal, 0 else.
// Censored values (a run that never met its quality target) enter as +inf:
// they sort last, quantiles and the IQM are +inf when they reach into the
// statistic (the IQM is finite while at most floor(n / 4) runs are censored),
// and two of them are equal in P(X > Y). Nothing is dropped, nothing is
// imputed: an infinite bound reads "not reached within the runs' budgets".
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace atacom {

double quantile(std::vector<double> v, double q);  // v non-empty
double mean_of(const std::vector<double>& v);
double sample_std(const std::vector<double>& v);   // 0 for n = 1
double iqm(std::vector<double> v);

struct Interval {
  double low = 0, high = 0;
};
// The resampling stream of a cell: Rng(seed, stream), stream = fnv1a64(key).
uint64_t bootstrap_stream(const std::string& key);
// Fewer seeds than this: the report gives no interval and no P(improvement)
// (one or two seeds resampled or compared run against run would look like
// evidence and are not); tables say "n = 1: no interval" in a grey cell.
constexpr size_t kMinSeedsForInterval = 3;
// Percentile-bootstrap 95 % interval of the IQM of `v`.
Interval bootstrap_iqm_ci(const std::vector<double>& v, int resamples, uint64_t seed, uint64_t stream);

// P(X improves on Y); higher_better = false compares "less is better".
double probability_of_improvement(const std::vector<double>& x, const std::vector<double>& y, bool higher_better);

}  // namespace atacom
