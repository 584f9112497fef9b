// Running observation normalisation (PPO): per-dimension mean and variance
// of every observation the learner acted on, merged batch by batch in
// float64 (Chan et al.'s pairwise update, one fixed order), and the float
// map ObsNorm that acts with them: (x - mean) / sqrt(var + 1e-8), clipped to
// +-10. The map is refreshed after each merge; policies act through it and
// policy files store it, so a policy file normalises exactly as the run did.
#pragma once
#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

#include "src/core/binary_io.hpp"
#include "train/obs_norm.hpp"

namespace atacom {

class RunningObsNorm {
 public:
  // d dimensions; disabled: the map stays the identity and merge() does nothing.
  void init(int d, bool enabled) {
    enabled_ = enabled;
    count_ = 0;
    mean_.assign(size_t(d), 0.0);
    m2_.assign(size_t(d), 0.0);
    batch_mean_.assign(size_t(d), 0.0);
    batch_m2_.assign(size_t(d), 0.0);
    map_.d = d;
    map_.mid.assign(size_t(d), 0.0f);
    map_.inv_half.assign(size_t(d), 1.0f);
    map_.on.assign(size_t(d), enabled ? 1 : 0);
  }

  // Adds n observations (n x d), then refreshes the map.
  void merge(const float* x, int n) {
    if (!enabled_ || n <= 0) return;
    const int d = map_.d;
    for (int j = 0; j < d; ++j) batch_mean_[size_t(j)] = batch_m2_[size_t(j)] = 0.0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < d; ++j) batch_mean_[size_t(j)] += double(x[size_t(i) * d + j]);
    for (int j = 0; j < d; ++j) batch_mean_[size_t(j)] /= n;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < d; ++j) {
        const double e = double(x[size_t(i) * d + j]) - batch_mean_[size_t(j)];
        batch_m2_[size_t(j)] += e * e;
      }
    const double na = double(count_), nb = double(n), nt = na + nb;
    for (int j = 0; j < d; ++j) {
      const double delta = batch_mean_[size_t(j)] - mean_[size_t(j)];
      mean_[size_t(j)] += delta * nb / nt;
      m2_[size_t(j)] += batch_m2_[size_t(j)] + delta * delta * na * nb / nt;
    }
    count_ += n;
    refresh();
  }

  const ObsNorm& map() const { return map_; }
  int64_t count() const { return count_; }
  double mean(int j) const { return mean_[size_t(j)]; }
  double var(int j) const { return count_ > 0 ? m2_[size_t(j)] / double(count_) : 1.0; }

  void save(std::ostream& out) const {
    bin::write_pod<uint8_t>(out, enabled_ ? 1 : 0);
    bin::write_pod<int64_t>(out, count_);
    bin::write_vec(out, mean_);
    bin::write_vec(out, m2_);
  }
  // The same dimension and mode; the map is rebuilt from the statistics.
  void load(std::istream& in) {
    const auto en = bin::read_pod<uint8_t>(in, "obs_norm.enabled");
    const auto count = bin::read_pod<int64_t>(in, "obs_norm.count");
    if ((en != 0) != enabled_) throw std::runtime_error("observation normalisation: the checkpoint's mode differs");
    if (count < 0) throw std::runtime_error("observation normalisation: negative count");
    bin::read_vec(in, mean_, "obs_norm.mean", map_.d);
    bin::read_vec(in, m2_, "obs_norm.m2", map_.d);
    for (int j = 0; j < map_.d; ++j)
      if (!std::isfinite(mean_[size_t(j)]) || !(m2_[size_t(j)] >= 0) || !std::isfinite(m2_[size_t(j)]))
        throw std::runtime_error("observation normalisation holds a non-finite or negative statistic");
    count_ = count;
    if (enabled_) refresh();  // with no observation yet: the identity, as init() left it
  }

 private:
  void refresh() {
    for (int j = 0; j < map_.d; ++j) {
      map_.mid[size_t(j)] = float(mean_[size_t(j)]);
      map_.inv_half[size_t(j)] = float(1.0 / std::sqrt(var(j) + 1e-8));
    }
  }

  bool enabled_ = false;
  int64_t count_ = 0;
  std::vector<double> mean_, m2_;               // (d) running mean, sum of squared deviations
  std::vector<double> batch_mean_, batch_m2_;  // (d) scratch of merge()
  ObsNorm map_;
};

}  // namespace atacom
