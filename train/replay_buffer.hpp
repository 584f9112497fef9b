// Replay buffer: structure of arrays, float32, ring, seeded sampling.
//
// All capacity is allocated up front (no allocation while training). Rows are
// written at head and overwrite the oldest once full. sample() draws indices
// uniformly with replacement from the given stream and gathers them into a
// preallocated ReplayBatch.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <vector>

#include "atacom/rng.hpp"
#include "train/tensor.hpp"

namespace atacom {

struct ReplayBatch {
  int B = 0;
  AlignedVector<float> obs;        // (B x obs_dim)
  AlignedVector<float> action;     // (B x act_dim)
  AlignedVector<float> reward;     // (B)
  AlignedVector<float> cost;       // (B)
  AlignedVector<float> next_obs;   // (B x obs_dim)
  AlignedVector<float> terminated; // (B) 1: no bootstrap
  AlignedVector<float> truncated;  // (B) 1: episode cut by the horizon (bootstrap)
  void resize(int B, int obs_dim, int act_dim);
};

class ReplayBuffer {
 public:
  ReplayBuffer() = default;
  ReplayBuffer(int64_t capacity, int obs_dim, int act_dim);

  // Append n rows; obs/next_obs (n x obs_dim), action (n x act_dim) as double
  // (the env's action type), the rest (n).
  void add(int n, const float* obs, const double* action, const float* reward, const float* cost,
           const float* next_obs, const uint8_t* terminated, const uint8_t* truncated);
  void sample(Rng& rng, ReplayBatch& out) const;  // out sized with resize(B, ...)

  int64_t size() const { return size_; }
  int64_t capacity() const { return capacity_; }
  int obs_dim() const { return obs_dim_; }
  int act_dim() const { return act_dim_; }

  // Saves only the filled rows; load() requires the same shape and capacity.
  void save(std::ostream& out) const;
  void load(std::istream& in);

 private:
  int64_t capacity_ = 0, size_ = 0, head_ = 0;
  int obs_dim_ = 0, act_dim_ = 0;
  std::vector<float> obs_;         // (capacity x obs_dim)
  std::vector<float> action_;      // (capacity x act_dim)
  std::vector<float> reward_;      // (capacity)
  std::vector<float> cost_;        // (capacity)
  std::vector<float> next_obs_;    // (capacity x obs_dim)
  std::vector<uint8_t> terminated_;// (capacity)
  std::vector<uint8_t> truncated_; // (capacity)
};

}  // namespace atacom
