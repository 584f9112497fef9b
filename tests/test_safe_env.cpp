// SafeEnv on a minimal control-affine env: points on a line moving right
// towards a wall at x = 1 (velocity control, reward for going right).
#include <catch2/catch.hpp>

#include <istream>
#include <ostream>

#include "atacom/rng.hpp"
#include "atacom/safe_env.hpp"

using namespace atacom;

namespace {

class LineEnv final : public ControlAffineEnv {
 public:
  explicit LineEnv(int N) : x_(N, 0.0), t_(N, 0), rng_(N) {
    spec_.name = "line";
    spec_.obs_dim = 1;
    spec_.act_dim = 1;
    spec_.obs_low = {-2.0f};
    spec_.obs_high = {2.0f};
    spec_.dt = 0.1;
    spec_.horizon = 40;
    spec_.num_constraints = 1;
    spec_.constraint_tolerance = {1e-3};
    spec_.constraint_names = {"wall"};
    spec_.info_names = {"collision"};
    spec_.info_reduce = {InfoReduce::Sum};
    spec_.info_role = {InfoRole::AnyContact};
    buffers_.resize(spec_, N);
  }
  const EnvSpec& spec() const override { return spec_; }
  void seed(uint64_t s) override {
    for (size_t i = 0; i < rng_.size(); ++i) rng_[i].reseed(s, i);
    reset(nullptr);
  }
  void reset(const uint8_t* mask) override {
    for (int i = 0; i < num_envs(); ++i)
      if (!mask || mask[i]) reset_one(i);
  }
  void step(const double* a) override {
    for (int i = 0; i < num_envs(); ++i) {
      const double u = std::isfinite(a[i]) ? std::clamp(a[i], -1.0, 1.0) : 0.0;
      x_[i] += spec_.dt * u;
      ++t_[i];
      const double c = x_[i] - 1.0;
      buffers_.constraints[i] = c;
      const bool hit = c > 0.01;
      buffers_.reward[i] = static_cast<float>(hit ? -100.0 : x_[i]);
      buffers_.terminated[i] = hit;
      buffers_.truncated[i] = !hit && t_[i] >= spec_.horizon;
      buffers_.info[i] = hit ? 1.0f : 0.0f;
      buffers_.final_obs[i] = static_cast<float>(x_[i]);
      ret_ += buffers_.reward[i];
      if (buffers_.done(i)) reset_one(i);
      buffers_.obs[i] = static_cast<float>(x_[i]);
    }
  }
  void save_state(std::ostream& out) const override {
    out.write(reinterpret_cast<const char*>(x_.data()), x_.size() * sizeof(double));
  }
  void load_state(std::istream& in) override {
    in.read(reinterpret_cast<char*>(x_.data()), x_.size() * sizeof(double));
  }
  ProjectorModel projector_model() const override {
    ProjectorModel m = default_projector_model(1, 1, 1, 0);
    m.g_form = GForm::Diagonal;
    m.has_drift = false;
    m.K_c = 1.0 / spec_.dt;
    m.beta = {10.0};
    return m;
  }
  void constraint_model(ProjectorBatch& pb, int lo, int hi) const override {
    for (int i = lo; i < hi; ++i) {
      pb.G[i] = 1.0;
      pb.c[i] = x_[i] - 1.0;
      pb.Jq[i] = 1.0;
    }
  }

 private:
  void reset_one(int i) {
    x_[i] = rng_[i].uniform(-1.0, 0.5);
    t_[i] = 0;
    buffers_.obs[i] = static_cast<float>(x_[i]);
  }
  EnvSpec spec_;
  std::vector<double> x_;
  std::vector<int> t_;
  std::vector<Rng> rng_;
  double ret_ = 0;
};

}  // namespace

TEST_CASE("safe env: ATACOM keeps a greedy policy at the wall, the raw env collides", "[safe_env]") {
  const int N = 16;
  auto inner = std::make_unique<LineEnv>(N);
  const ProjectorModel model = inner->projector_model();
  SafeEnv env(std::move(inner), model);
  REQUIRE(env.spec().info_names.size() == 4);
  CHECK(env.spec().info_names[1] == "atacom_lambda");
  CHECK(env.spec().info_names[3] == "max_constraint");
  env.seed(3);
  LineEnv raw(N);
  raw.seed(3);
  CHECK(env.buffers().obs == raw.buffers().obs);
  std::vector<double> push(N, 1.0);
  double max_c = -1;
  long raw_hits = 0, safe_hits = 0;
  for (int s = 0; s < 200; ++s) {
    env.step(push.data());
    raw.step(push.data());
    for (int i = 0; i < N; ++i) {
      max_c = std::max(max_c, env.buffers().constraints[i]);
      safe_hits += env.buffers().terminated[i];
      raw_hits += raw.buffers().terminated[i];
      CHECK(env.buffers().info[i * 4 + 3] == Approx(env.buffers().constraints[i]).margin(1e-6));
    }
  }
  CHECK(safe_hits == 0);
  CHECK(raw_hits > 0);
  CHECK(max_c <= 1e-3);
  CHECK(max_c > -0.05);  // it did go all the way to the wall
  // NaN actions are a documented fallback (pure correction), not a crash.
  std::vector<double> nan(N, std::nan(""));
  env.step(nan.data());
  for (int i = 0; i < N; ++i) CHECK(std::isfinite(env.buffers().obs[i]));
}

TEST_CASE("safe env: mismatched projector model is rejected", "[safe_env]") {
  auto inner = std::make_unique<LineEnv>(2);
  ProjectorModel model = inner->projector_model();
  model.k = 2;
  model.slack.resize(2);
  model.beta.resize(2, 1.0);
  model.tol.resize(2, 1e-6);
  model.equality.resize(2, 0);
  CHECK_THROWS_WITH(SafeEnv(std::move(inner), model), Catch::Contains("constraints"));
}
