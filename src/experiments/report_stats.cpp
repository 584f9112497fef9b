#include "src/experiments/report_stats.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/rng.hpp"
#include "src/core/binary_io.hpp"

namespace atacom {

// Sums in long double (its range holds any sum of doubles: +-1e308 values
// give a finite mean, never inf or NaN).
namespace {
long double mean_ld(std::vector<double>::const_iterator b, std::vector<double>::const_iterator e) {
  long double s = 0;
  for (auto it = b; it != e; ++it) s += *it;
  return s / (long double)(e - b);
}
}  // namespace

double quantile(std::vector<double> v, double q) {
  if (v.empty()) throw std::invalid_argument("quantile of no values");
  std::sort(v.begin(), v.end());
  const double h = q * double(v.size() - 1);
  const size_t lo = size_t(std::floor(h));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  // Censored values are +inf: an order statistic itself, or between two equal
  // ones, is returned as it is (inf - inf would make NaN). The step between two
  // finite ones in long double (1e308 - -1e308 overflows a double).
  if (h == double(lo) || v[hi] == v[lo]) return v[lo];
  const long double t = h - double(lo);
  return double(v[lo] + t * ((long double)v[hi] - v[lo]));
}

double mean_of(const std::vector<double>& v) {
  return v.empty() ? std::nan("") : double(mean_ld(v.begin(), v.end()));
}

double sample_std(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const long double m = mean_ld(v.begin(), v.end());
  long double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return double(std::sqrt(s / (long double)(v.size() - 1)));
}

double iqm(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t cut = v.size() / 4;
  return double(mean_ld(v.begin() + long(cut), v.end() - long(cut)));
}

uint64_t bootstrap_stream(const std::string& key) { return bin::fnv1a(key.data(), key.size()); }

Interval bootstrap_iqm_ci(const std::vector<double>& v, int resamples, uint64_t seed, uint64_t stream) {
  if (v.empty()) return {std::nan(""), std::nan("")};
  Rng rng(seed, stream);
  std::vector<double> stats(static_cast<size_t>(resamples));
  std::vector<double> sample(v.size());
  for (int r = 0; r < resamples; ++r) {
    for (double& x : sample) x = v[rng.below(v.size())];
    stats[size_t(r)] = iqm(sample);
  }
  return {quantile(stats, 0.025), quantile(stats, 0.975)};
}

Interval bootstrap_improvement_ci(const std::vector<double>& x, const std::vector<double>& y, bool higher_better,
                                  int resamples, uint64_t seed, uint64_t stream) {
  if (x.empty() || y.empty()) return {std::nan(""), std::nan("")};
  Rng rng(seed, stream);
  std::vector<double> stats(static_cast<size_t>(resamples));
  std::vector<double> sx(x.size()), sy(y.size());
  for (int r = 0; r < resamples; ++r) {
    for (double& v : sx) v = x[rng.below(x.size())];
    for (double& v : sy) v = y[rng.below(y.size())];
    stats[size_t(r)] = probability_of_improvement(sx, sy, higher_better);
  }
  return {quantile(stats, 0.025), quantile(stats, 0.975)};
}

double probability_of_improvement(const std::vector<double>& x, const std::vector<double>& y, bool higher_better) {
  if (x.empty() || y.empty()) return std::nan("");
  double s = 0;
  for (double a : x)
    for (double b : y) {
      // Compared, not subtracted: two censored (+inf) values are equal.
      const bool better = higher_better ? a > b : a < b;
      s += better ? 1.0 : a == b ? 0.5 : 0.0;
    }
  return s / double(x.size() * y.size());
}

}  // namespace atacom
