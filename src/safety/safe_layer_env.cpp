#include "src/safety/safe_layer_env.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>

#include "atacom/parallel.hpp"

namespace atacom {

namespace {
constexpr int kBlock = 256;  // envs per task: constraint model + QP stay in cache together
}

SafeLayerEnv::SafeLayerEnv(std::unique_ptr<ControlAffineEnv> inner, const SafeLayerModel& model)
    : inner_(std::move(inner)), model_(model) {
  if (!inner_) throw std::invalid_argument("SafeLayerEnv: no inner env");
  model_.validate();
  pm_ = inner_->projector_model();
  const EnvSpec& is = inner_->spec();
  if (model_.m != is.act_dim || model_.k != is.num_constraints || model_.n != pm_.n || model_.p != pm_.p ||
      model_.g_form != pm_.g_form || model_.has_drift != pm_.has_drift)
    throw std::invalid_argument("SafeLayerEnv: the SafeLayer model's shapes do not match env '" + is.name + "'");
  spec_ = is;
  inner_info_ = static_cast<int>(is.info_names.size());
  spec_.info_names.insert(spec_.info_names.end(), {"safelayer_correction", "safelayer_active", "safelayer_iterations",
                                                   "safelayer_infeasible", "max_constraint"});
  spec_.info_reduce.insert(spec_.info_reduce.end(),
                           {InfoReduce::Mean, InfoReduce::Mean, InfoReduce::Mean, InfoReduce::Sum, InfoReduce::Max});
  pb_.resize(pm_, inner_->num_envs());
  out_.resize(model_, inner_->num_envs());
  buffers_.resize(spec_, inner_->num_envs());
  mirror_rows(0, inner_->num_envs());
}

void SafeLayerEnv::seed(uint64_t seed) {
  inner_->seed(seed);
  mirror_rows(0, inner_->num_envs());
}

void SafeLayerEnv::reset(const uint8_t* mask) {
  inner_->reset(mask);
  mirror_rows(0, inner_->num_envs());
}

void SafeLayerEnv::load_state(std::istream& in) {
  inner_->load_state(in);
  mirror_rows(0, inner_->num_envs());
}

void SafeLayerEnv::step(const double* actions) {
  const int N = inner_->num_envs();
  std::copy_n(actions, size_t(N) * model_.m, pb_.alpha.data());
  parallel_blocks(N, kBlock, [&](int64_t lo, int64_t hi) {
    const auto t0 = profiling_ ? std::chrono::steady_clock::now() : std::chrono::steady_clock::time_point{};
    inner_->constraint_model(pb_, static_cast<int>(lo), static_cast<int>(hi));
    safelayer_range(model_, pb_, out_, static_cast<int>(lo), static_cast<int>(hi));
    if (profiling_)
      layer_ns_.fetch_add(
          std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count(),
          std::memory_order_relaxed);
  });
  inner_->step(out_.a.data());
  const int k = model_.k;
  const size_t ni = spec_.info_names.size();
  parallel_blocks(N, kBlock, [&](int64_t lo, int64_t hi) {
    mirror_rows(static_cast<int>(lo), static_cast<int>(hi));
    for (int64_t i = lo; i < hi; ++i) {
      float* info = buffers_.info.data() + size_t(i) * ni + inner_info_;
      info[0] = static_cast<float>(out_.correction[i]);
      info[1] = static_cast<float>(out_.active[i]);
      info[2] = static_cast<float>(out_.iterations[i]);
      info[3] = (out_.status[i] & (kSafeLayerInfeasible | kSafeLayerModelNonFinite)) ? 1.0f : 0.0f;
      const double* c = buffers_.constraints.data() + size_t(i) * k;
      double mx = k ? c[0] : 0.0;
      for (int r = 1; r < k; ++r) mx = std::max(mx, c[r]);
      info[4] = static_cast<float>(mx);
    }
  });
}

std::vector<std::string> SafeLayerEnv::profile_sections() const {
  std::vector<std::string> s = inner_->profile_sections();
  s.push_back("safelayer");
  return s;
}

void SafeLayerEnv::set_profiling(bool on) {
  inner_->set_profiling(on);
  profiling_ = on;
  layer_ns_.store(0);
}

std::vector<double> SafeLayerEnv::profile_seconds() const {
  std::vector<double> s = inner_->profile_seconds();
  s.resize(inner_->profile_sections().size(), 0.0);
  s.push_back(layer_ns_.load() * 1e-9);
  return s;
}

void SafeLayerEnv::mirror_rows(int lo, int hi) {
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
