// Observation normalisation of the SAC learner: the spec's bounds mapped to
// [-1, 1], clipped to +-10 (the paper's MinMax preprocessor); dimensions
// without finite, ordered bounds pass through unchanged.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iosfwd>
#include <vector>

#include "atacom/env.hpp"
#include "src/core/binary_io.hpp"

namespace atacom {

struct ObsNorm {
  int d = 0;
  std::vector<float> mid, inv_half;  // (d)
  std::vector<uint8_t> on;           // (d) 1: normalised, 0: passed through

  void init(const EnvSpec& s, bool enabled) {
    d = s.obs_dim;
    mid.assign(size_t(d), 0.0f);
    inv_half.assign(size_t(d), 1.0f);
    on.assign(size_t(d), 0);
    if (!enabled || s.obs_low.size() != size_t(d) || s.obs_high.size() != size_t(d)) return;
    for (int j = 0; j < d; ++j) {
      const float lo = s.obs_low[size_t(j)], hi = s.obs_high[size_t(j)];
      if (std::isfinite(lo) && std::isfinite(hi) && hi > lo) {
        mid[size_t(j)] = 0.5f * (lo + hi);
        inv_half[size_t(j)] = 2.0f / (hi - lo);
        on[size_t(j)] = 1;
      }
    }
  }
  // out (n x d) from in (n x d); in == out is allowed.
  void apply(const float* in, float* out, int n) const {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < d; ++j) {
        const size_t k = size_t(i) * d + j;
        out[k] = on[size_t(j)] ? std::min(std::max((in[k] - mid[size_t(j)]) * inv_half[size_t(j)], -10.0f), 10.0f)
                               : in[k];
      }
  }
  void save(std::ostream& out) const {
    bin::write_pod<int32_t>(out, d);
    bin::write_vec(out, mid);
    bin::write_vec(out, inv_half);
    bin::write_vec(out, on);
  }
  // Requires the same dimension; the values come from the file.
  void load(std::istream& in) {
    const auto dd = bin::read_pod<int32_t>(in, "obs_norm.dim");
    if (dd != d) throw std::runtime_error("observation normalisation is for " + std::to_string(dd) +
                                          " dims, expected " + std::to_string(d));
    bin::read_vec(in, mid, "obs_norm.mid", d);
    bin::read_vec(in, inv_half, "obs_norm.inv_half", d);
    bin::read_vec(in, on, "obs_norm.on", d);
    for (int j = 0; j < d; ++j)
      if (!std::isfinite(mid[size_t(j)]) || !std::isfinite(inv_half[size_t(j)]) || on[size_t(j)] > 1)
        throw std::runtime_error("observation normalisation holds a non-finite or invalid value");
  }
};

}  // namespace atacom
