#include "train/replay_buffer.hpp"

#include <cstring>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

#include "src/core/binary_io.hpp"
#include "src/core/limits.hpp"

namespace atacom {

void ReplayBatch::resize(int b, int obs_dim, int act_dim) {
  B = b;
  obs.assign(size_t(b) * obs_dim, 0.0f);
  action.assign(size_t(b) * act_dim, 0.0f);
  reward.assign(size_t(b), 0.0f);
  cost.assign(size_t(b), 0.0f);
  next_obs.assign(size_t(b) * obs_dim, 0.0f);
  terminated.assign(size_t(b), 0.0f);
  truncated.assign(size_t(b), 0.0f);
}

ReplayBuffer::ReplayBuffer(int64_t capacity, int obs_dim, int act_dim)
    : capacity_(capacity), obs_dim_(obs_dim), act_dim_(act_dim) {
  if (capacity < 1 || obs_dim < 1 || act_dim < 1)
    throw std::invalid_argument("replay buffer: capacity and dimensions must be positive");
  const size_t c = size_t(capacity);
  // Checked before allocating: a capacity the machine cannot hold is an error naming the key, not std::bad_alloc.
  limits::require_memory(double(c) * (sizeof(float) * (2.0 * obs_dim + act_dim + 2) + 2),
                         "sac.replay_capacity = " + std::to_string(capacity) + " (replay buffer of " +
                             std::to_string(obs_dim) + "-dim observations)");
  obs_.assign(c * obs_dim, 0.0f);
  action_.assign(c * act_dim, 0.0f);
  reward_.assign(c, 0.0f);
  cost_.assign(c, 0.0f);
  next_obs_.assign(c * obs_dim, 0.0f);
  terminated_.assign(c, 0);
  truncated_.assign(c, 0);
}

void ReplayBuffer::add(int n, const float* obs, const double* action, const float* reward, const float* cost,
                       const float* next_obs, const uint8_t* terminated, const uint8_t* truncated) {
  for (int i = 0; i < n; ++i) {
    const size_t h = size_t(head_);
    std::memcpy(&obs_[h * obs_dim_], obs + size_t(i) * obs_dim_, sizeof(float) * obs_dim_);
    std::memcpy(&next_obs_[h * obs_dim_], next_obs + size_t(i) * obs_dim_, sizeof(float) * obs_dim_);
    for (int j = 0; j < act_dim_; ++j) action_[h * act_dim_ + j] = static_cast<float>(action[size_t(i) * act_dim_ + j]);
    reward_[h] = reward[i];
    cost_[h] = cost[i];
    terminated_[h] = terminated[i] ? 1 : 0;
    truncated_[h] = truncated[i] ? 1 : 0;
    head_ = (head_ + 1) % capacity_;
    if (size_ < capacity_) ++size_;
  }
}

void ReplayBuffer::sample(Rng& rng, ReplayBatch& out) const {
  if (size_ == 0) throw std::logic_error("replay buffer: sample() on an empty buffer");
  for (int b = 0; b < out.B; ++b) {
    const size_t k = size_t(rng.below(uint64_t(size_)));
    std::memcpy(&out.obs[size_t(b) * obs_dim_], &obs_[k * obs_dim_], sizeof(float) * obs_dim_);
    std::memcpy(&out.next_obs[size_t(b) * obs_dim_], &next_obs_[k * obs_dim_], sizeof(float) * obs_dim_);
    std::memcpy(&out.action[size_t(b) * act_dim_], &action_[k * act_dim_], sizeof(float) * act_dim_);
    out.reward[b] = reward_[k];
    out.cost[b] = cost_[k];
    out.terminated[b] = terminated_[k];
    out.truncated[b] = truncated_[k];
  }
}

namespace {
template <class V>
void write_rows(std::ostream& out, const std::vector<V>& v, int64_t rows, int width) {
  out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(size_t(rows) * width * sizeof(V)));
}
template <class V>
void read_rows(std::istream& in, std::vector<V>& v, int64_t rows, int width, const char* what) {
  const auto bytes = std::streamsize(size_t(rows) * width * sizeof(V));
  in.read(reinterpret_cast<char*>(v.data()), bytes);
  if (!in || in.gcount() != bytes) throw std::runtime_error(std::string("snapshot truncated while reading ") + what);
}
}  // namespace

void ReplayBuffer::save(std::ostream& out) const {
  bin::write_pod<int64_t>(out, capacity_);
  bin::write_pod<int32_t>(out, obs_dim_);
  bin::write_pod<int32_t>(out, act_dim_);
  bin::write_pod<int64_t>(out, size_);
  bin::write_pod<int64_t>(out, head_);
  write_rows(out, obs_, size_, obs_dim_);
  write_rows(out, action_, size_, act_dim_);
  write_rows(out, reward_, size_, 1);
  write_rows(out, cost_, size_, 1);
  write_rows(out, next_obs_, size_, obs_dim_);
  write_rows(out, terminated_, size_, 1);
  write_rows(out, truncated_, size_, 1);
}

void ReplayBuffer::load(std::istream& in) {
  const auto cap = bin::read_pod<int64_t>(in, "replay.capacity");
  const auto od = bin::read_pod<int32_t>(in, "replay.obs_dim");
  const auto ad = bin::read_pod<int32_t>(in, "replay.act_dim");
  if (cap != capacity_ || od != obs_dim_ || ad != act_dim_)
    throw std::runtime_error("replay buffer snapshot has capacity " + std::to_string(cap) + " and dims " +
                             std::to_string(od) + "/" + std::to_string(ad) + ", expected " +
                             std::to_string(capacity_) + " and " + std::to_string(obs_dim_) + "/" +
                             std::to_string(act_dim_));
  const auto size = bin::read_pod<int64_t>(in, "replay.size");
  const auto head = bin::read_pod<int64_t>(in, "replay.head");
  if (size < 0 || size > capacity_ || head < 0 || head >= capacity_ || (size < capacity_ && head != size))
    throw std::runtime_error("replay buffer snapshot has inconsistent size/head");
  read_rows(in, obs_, size, obs_dim_, "replay.obs");
  read_rows(in, action_, size, act_dim_, "replay.action");
  read_rows(in, reward_, size, 1, "replay.reward");
  read_rows(in, cost_, size, 1, "replay.cost");
  read_rows(in, next_obs_, size, obs_dim_, "replay.next_obs");
  read_rows(in, terminated_, size, 1, "replay.terminated");
  read_rows(in, truncated_, size, 1, "replay.truncated");
  size_ = size;
  head_ = head;
}

}  // namespace atacom
