#include "atacom/layered_env.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "atacom/parallel.hpp"

namespace atacom {

namespace {
}

LayeredEnv::LayeredEnv(std::unique_ptr<ControlAffineEnv> inner, const char* layer, std::string section,
                       const std::vector<InfoColumn>& columns)
    : inner_(std::move(inner)), section_(std::move(section)) {
  if (!inner_) throw std::invalid_argument(std::string(layer) + ": no inner env");
  spec_ = inner_->spec();
  inner_info_ = static_cast<int>(spec_.info_names.size());
  for (const InfoColumn& c : columns) {
    spec_.info_names.emplace_back(c.name);
    spec_.info_reduce.push_back(c.reduce);
  }
  spec_.info_names.emplace_back("max_constraint");
  spec_.info_reduce.push_back(InfoReduce::Max);
  buffers_.resize(spec_, inner_->num_envs());
  mirror_rows(0, inner_->num_envs());
}

void LayeredEnv::seed(uint64_t seed) {
  inner_->seed(seed);
  mirror_rows(0, inner_->num_envs());
}

void LayeredEnv::reset(const uint8_t* mask) {
  inner_->reset(mask);
  mirror_rows(0, inner_->num_envs());
}

void LayeredEnv::load_state(std::istream& in) {
  inner_->load_state(in);
  mirror_rows(0, inner_->num_envs());
}

void LayeredEnv::step(const double* actions) {
  const int N = inner_->num_envs();
  take_actions(actions);
  // Constraint model and correction of one block run back to back, so the
  // Jacobians the env just wrote are still in cache when the layer reads them.
  parallel_blocks(N, kEnvBlock, [&](int64_t lo, int64_t hi) {
    const auto t0 = profiling_ ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
    correct_range(static_cast<int>(lo), static_cast<int>(hi));
    if (profiling_)
      layer_ns_.fetch_add(
          std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count(),
          std::memory_order_relaxed);
  });
  inner_->step(controls());
  // Mirror the inner buffers and fill the layer's info columns block-parallel
  // (a serial copy was about a tenth of the step at N = 4096).
  const int k = spec_.num_constraints;
  const size_t ni = spec_.info_names.size();
  parallel_blocks(N, kEnvBlock, [&](int64_t lo, int64_t hi) {
    mirror_rows(static_cast<int>(lo), static_cast<int>(hi));
    for (int64_t i = lo; i < hi; ++i) {
      float* info = buffers_.info.data() + size_t(i) * ni + inner_info_;
      write_info(i, info);
      const double* c = buffers_.constraints.data() + size_t(i) * k;
      double mx = k ? c[0] : 0.0;
      for (int r = 1; r < k; ++r) mx = std::max(mx, c[r]);
      info[ni - inner_info_ - 1] = static_cast<float>(mx);
    }
  });
}

std::vector<std::string> LayeredEnv::profile_sections() const {
  std::vector<std::string> s = inner_->profile_sections();
  s.push_back(section_);
  return s;
}

void LayeredEnv::set_profiling(bool on) {
  inner_->set_profiling(on);
  profiling_ = on;
  layer_ns_.store(0);
}

std::vector<double> LayeredEnv::profile_seconds() const {
  std::vector<double> s = inner_->profile_seconds();
  s.resize(inner_->profile_sections().size(), 0.0);
  s.push_back(layer_ns_.load() * 1e-9);
  return s;
}

void LayeredEnv::mirror_rows(int lo, int hi) {
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
  rows(in.cost_continuous, out.cost_continuous, 1);
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
