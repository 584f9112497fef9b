#include "train/ppo_rollout.hpp"

#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

#include "atacom/parallel.hpp"
#include "src/core/binary_io.hpp"

namespace atacom {

void PpoRollout::resize(int t, int n, int d, int a, bool costs) {
  T = t, N = n, D = d, A = a;
  steps = finals = 0;
  const size_t rows = size_t(T) * size_t(N);
  obs.assign(rows * size_t(D), 0.0f);
  sample.assign(rows * size_t(A), 0.0f);
  logp.assign(rows, 0.0f);
  reward.assign(rows, 0.0f);
  terminated.assign(rows, 0);
  truncated.assign(rows, 0);
  final_row.assign(rows, -1);
  final_obs.assign(rows * size_t(D), 0.0f);
  last_obs.assign(size_t(N) * size_t(D), 0.0f);
  value.assign(rows, 0.0f);
  final_value.assign(rows, 0.0f);
  last_value.assign(size_t(N), 0.0f);
  advantage.assign(rows, 0.0f);
  ret.assign(rows, 0.0f);
  with_cost = costs;
  for (auto* v : {&cost, &cost_value, &cost_final_value, &cost_advantage, &cost_ret}) v->assign(costs ? rows : 0, 0.0f);
  cost_last_value.assign(costs ? size_t(N) : 0, 0.0f);
}

namespace {
constexpr uint32_t kTagRollout = 0x50504f52;  // "PPOR"

template <class T>
void write_rows(std::ostream& out, const T* p, size_t n) {
  bin::write_pod<uint64_t>(out, n);
  if (n) out.write(reinterpret_cast<const char*>(p), static_cast<std::streamsize>(n * sizeof(T)));
}
// Reads exactly n values written by write_rows into p (storage already sized).
template <class T>
void read_rows(std::istream& in, T* p, size_t n, const char* what) {
  const auto got = bin::read_pod<uint64_t>(in, what);
  if (got != n)
    throw std::runtime_error(std::string("PPO rollout field ") + what + " has " + std::to_string(got) +
                             " values, expected " + std::to_string(n));
  if (!n) return;
  in.read(reinterpret_cast<char*>(p), static_cast<std::streamsize>(n * sizeof(T)));
  if (!in || in.gcount() != static_cast<std::streamsize>(n * sizeof(T)))
    throw std::runtime_error(std::string("snapshot truncated while reading ") + what);
}
}  // namespace

void PpoRollout::save(std::ostream& out) const {
  bin::write_tag(out, kTagRollout);
  bin::write_pod<int32_t>(out, steps);
  bin::write_pod<int32_t>(out, finals);
  const size_t r = size_t(rows());
  write_rows(out, obs.data(), r * size_t(D));
  write_rows(out, sample.data(), r * size_t(A));
  write_rows(out, logp.data(), r);
  write_rows(out, reward.data(), r);
  write_rows(out, terminated.data(), r);
  write_rows(out, truncated.data(), r);
  write_rows(out, final_row.data(), r);
  write_rows(out, final_obs.data(), size_t(finals) * size_t(D));
  if (with_cost) write_rows(out, cost.data(), r);
}

void PpoRollout::load(std::istream& in) {
  bin::expect_tag(in, kTagRollout, "ppo rollout");
  const auto s = bin::read_pod<int32_t>(in, "ppo_rollout.steps");
  const auto f = bin::read_pod<int32_t>(in, "ppo_rollout.finals");
  // A full rollout is consumed by the update in the same observe(): a
  // checkpoint holds at most T - 1 steps.
  if (s < 0 || s >= T) throw std::runtime_error("PPO rollout holds " + std::to_string(s) + " steps, must be in [0, " +
                                                std::to_string(T - 1) + "]");
  const size_t r = size_t(s) * size_t(N);
  if (f < 0 || size_t(f) > r) throw std::runtime_error("PPO rollout: final observation count out of range");
  steps = s;
  finals = f;
  read_rows(in, obs.data(), r * size_t(D), "ppo_rollout.obs");
  read_rows(in, sample.data(), r * size_t(A), "ppo_rollout.sample");
  read_rows(in, logp.data(), r, "ppo_rollout.logp");
  read_rows(in, reward.data(), r, "ppo_rollout.reward");
  read_rows(in, terminated.data(), r, "ppo_rollout.terminated");
  read_rows(in, truncated.data(), r, "ppo_rollout.truncated");
  read_rows(in, final_row.data(), r, "ppo_rollout.final_row");
  read_rows(in, final_obs.data(), size_t(f) * size_t(D), "ppo_rollout.final_obs");
  if (with_cost) {
    read_rows(in, cost.data(), r, "ppo_rollout.cost");
    for (size_t k = 0; k < r; ++k)
      if (!(cost[k] >= 0.0f && cost[k] <= 1.0f)) throw std::runtime_error("PPO rollout holds a cost outside [0, 1]");
  }
  // Every truncated row owns the next final slot, in row order.
  int32_t next = 0;
  for (size_t k = 0; k < r; ++k) {
    if (terminated[k] > 1 || truncated[k] > 1 || (terminated[k] && truncated[k]))
      throw std::runtime_error("PPO rollout: invalid episode flags");
    if (truncated[k] ? final_row[k] != next++ : final_row[k] != -1)
      throw std::runtime_error("PPO rollout: final observation index out of order");
  }
  if (next != f) throw std::runtime_error("PPO rollout: final observation count does not match the truncated rows");
  for (size_t k = 0; k < r; ++k)
    if (!std::isfinite(logp[k]) || !std::isfinite(reward[k]))
      throw std::runtime_error("PPO rollout holds a non-finite log-density or reward");
}

void compute_gae(int T, int N, const float* reward, const float* value, const float* last_value,
                 const uint8_t* terminated, const uint8_t* truncated, const int32_t* final_row,
                 const float* final_value, double gamma, double lambda, float* advantage, float* ret) {
  parallel_blocks(N, 256, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      double carry = 0.0;  // A_{t+1}, 0 past an episode's end
      double next_v = double(last_value[i]);
      for (int t = T - 1; t >= 0; --t) {
        const size_t k = size_t(t) * size_t(N) + size_t(i);
        const double v = double(value[k]);
        double boot = next_v;
        if (terminated[k]) boot = 0.0, carry = 0.0;
        else if (truncated[k]) boot = double(final_value[final_row[k]]), carry = 0.0;
        const double delta = double(reward[k]) + gamma * boot - v;
        carry = delta + gamma * lambda * carry;
        advantage[k] = float(carry);
        ret[k] = float(carry + v);
        next_v = v;
      }
    }
  });
}

}  // namespace atacom
