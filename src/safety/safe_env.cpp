#include "atacom/safe_env.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "atacom/parallel.hpp"

namespace atacom {

namespace {
constexpr int kBlock = 256;  // envs per task: constraint model + projection stay in cache together
}

SafeEnv::SafeEnv(std::unique_ptr<ControlAffineEnv> inner, const ProjectorModel& model)
    : inner_(std::move(inner)), model_(model) {
  if (!inner_) throw std::invalid_argument("SafeEnv: no inner env");
  model_.validate();
  const EnvSpec& is = inner_->spec();
  if (model_.m != is.act_dim)
    throw std::invalid_argument("SafeEnv: projector has m = " + std::to_string(model_.m) + " controls but env '" +
                                is.name + "' has " + std::to_string(is.act_dim) + " actions");
  if (model_.k != is.num_constraints)
    throw std::invalid_argument("SafeEnv: projector has k = " + std::to_string(model_.k) + " rows but env '" +
                                is.name + "' reports " + std::to_string(is.num_constraints) + " constraints");
  spec_ = is;
  inner_info_ = static_cast<int>(is.info_names.size());
  spec_.info_names.insert(spec_.info_names.end(), {"atacom_lambda", "atacom_bias_out", "max_constraint"});
  spec_.info_reduce.insert(spec_.info_reduce.end(), {InfoReduce::Mean, InfoReduce::Sum, InfoReduce::Max});
  pb_.resize(model_, inner_->num_envs());
  buffers_.resize(spec_, inner_->num_envs());
  mirror_buffers();
}

void SafeEnv::seed(uint64_t seed) {
  inner_->seed(seed);
  mirror_buffers();
}

void SafeEnv::reset(const uint8_t* mask) {
  inner_->reset(mask);
  mirror_buffers();
}

void SafeEnv::load_state(std::istream& in) {
  inner_->load_state(in);
  mirror_buffers();
}

void SafeEnv::step(const double* alpha) {
  const int N = inner_->num_envs();
  const int m = model_.m;
  std::copy_n(alpha, size_t(N) * m, pb_.alpha.data());
  // Constraint model and projection of one block run back to back, so the
  // Jacobians the env just wrote are still in cache when the kernel reads them.
  parallel_blocks(N, kBlock, [&](int64_t lo, int64_t hi) {
    const auto t0 = profiling_ ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
    inner_->constraint_model(pb_, static_cast<int>(lo), static_cast<int>(hi));
    // The env only needs a (and lambda/status); skipping the slack outputs
    // saves a fifth of the kernel's memory traffic.
    project_range(model_, pb_, static_cast<int>(lo), static_cast<int>(hi), {.store_slack = false});
    if (profiling_)
      projector_ns_.fetch_add(
          std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count(),
          std::memory_order_relaxed);
  });
  inner_->step(pb_.a.data());
  // Mirror the inner buffers and fill ATACOM's info columns block-parallel
  // (a serial copy was about a tenth of the step at N = 4096).
  const int k = model_.k;
  const size_t ni = spec_.info_names.size();
  parallel_blocks(N, kBlock, [&](int64_t lo, int64_t hi) {
    mirror_rows(static_cast<int>(lo), static_cast<int>(hi));
    for (int64_t i = lo; i < hi; ++i) {
      float* info = buffers_.info.data() + size_t(i) * ni + inner_info_;
      info[0] = static_cast<float>(pb_.lambda[i]);
      info[1] = (pb_.status[i] & (kStatusBiasOutOfBounds | kStatusModelNonFinite)) ? 1.0f : 0.0f;
      const double* c = buffers_.constraints.data() + size_t(i) * k;
      double mx = k ? c[0] : 0.0;
      for (int r = 1; r < k; ++r) mx = std::max(mx, c[r]);
      info[2] = static_cast<float>(mx);
    }
  });
}

std::vector<std::string> SafeEnv::profile_sections() const {
  std::vector<std::string> s = inner_->profile_sections();
  s.push_back("projector");
  return s;
}

void SafeEnv::set_profiling(bool on) {
  inner_->set_profiling(on);
  profiling_ = on;
  projector_ns_.store(0);
}

std::vector<double> SafeEnv::profile_seconds() const {
  std::vector<double> s = inner_->profile_seconds();
  s.resize(inner_->profile_sections().size(), 0.0);
  s.push_back(projector_ns_.load() * 1e-9);
  return s;
}

void SafeEnv::mirror_buffers() { mirror_rows(0, inner_->num_envs()); }

void SafeEnv::mirror_rows(int lo, int hi) {
  const EnvBuffers& in = inner_->buffers();
  EnvBuffers& out = buffers_;
  auto rows = [lo, hi](const auto& src, auto& dst, size_t width) {
    std::copy(src.begin() + size_t(lo) * width, src.begin() + size_t(hi) * width, dst.begin() + size_t(lo) * width);
  };
  const size_t d = static_cast<size_t>(spec_.obs_dim), k = static_cast<size_t>(spec_.num_constraints);
  rows(in.obs, out.obs, d);
  rows(in.final_obs, out.final_obs, d);
  rows(in.reward, out.reward, 1);
  rows(in.cost, out.cost, 1);
  rows(in.terminated, out.terminated, 1);
  rows(in.truncated, out.truncated, 1);
  rows(in.constraints, out.constraints, k);
  rows(in.episode_return, out.episode_return, 1);
  rows(in.episode_length, out.episode_length, 1);
  const size_t ni = spec_.info_names.size(), nin = static_cast<size_t>(inner_info_);
  for (int i = lo; i < hi; ++i)
    std::copy_n(in.info.data() + size_t(i) * nin, nin, out.info.data() + size_t(i) * ni);
}

}  // namespace atacom
