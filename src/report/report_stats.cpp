#include "src/report/report_stats.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "atacom/rng.hpp"

namespace atacom {

double quantile(std::vector<double> v, double q) {
  if (v.empty()) throw std::invalid_argument("quantile of no values");
  std::sort(v.begin(), v.end());
  const double h = q * double(v.size() - 1);
  const size_t lo = size_t(std::floor(h));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  // Censored values are +inf: an order statistic itself, or between two equal
  // ones, is returned as it is (inf - inf would make NaN).
  if (h == double(lo) || v[hi] == v[lo]) return v[lo];
  return v[lo] + (h - double(lo)) * (v[hi] - v[lo]);
}

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? std::nan("") : s / double(v.size());
}

double sample_std(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = mean_of(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / double(v.size() - 1));
}

double iqm(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t cut = v.size() / 4;
  double s = 0;
  for (size_t i = cut; i < v.size() - cut; ++i) s += v[i];
  return s / double(v.size() - 2 * cut);
}

uint64_t bootstrap_stream(const std::string& key) {
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : key) {
    h ^= c;
    h *= 0x100000001b3ull;
  }
  return h;
}

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
