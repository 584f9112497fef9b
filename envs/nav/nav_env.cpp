// NavEnv: the navigation env's model, batch and Box2D worlds, stepped by the
// range kernels of envs/nav/nav_kernels.hpp over fixed parallel blocks.
#include "envs/nav/nav_env.hpp"

#include <algorithm>
#include <istream>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "envs/nav/nav_batch_fields.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

namespace {

constexpr uint32_t kTagNav = snapshot_tag("NAV ");

int checked_num_envs(int num_envs) {
  if (num_envs < 1) throw std::invalid_argument("NavEnv: number of envs must be >= 1");
  return num_envs;
}

}  // namespace

NavEnv::NavEnv(const NavConfig& config, int num_envs)
    : model_(config), worlds_(model_.config, checked_num_envs(num_envs)) {
  buffers_.resize(model_.spec, num_envs);
  st_.resize(num_envs);
  const int blocks = (num_envs + model_.config.block - 1) / model_.config.block;
  profile_.assign(static_cast<size_t>(blocks), NavProfile{});
  seed(0);
}

NavEnv::~NavEnv() = default;

void NavEnv::seed(uint64_t seed) {
  for (int i = 0; i < st_.N; ++i) st_.rng[i].reseed(seed, static_cast<uint64_t>(i));
  reset(nullptr);
}

void NavEnv::reset(const uint8_t* mask) {
  parallel_blocks(st_.N, model_.config.block, [&](int64_t lo, int64_t hi) {
    nav_reset_range(model_, st_, worlds_, buffers_, mask, static_cast<int>(lo), static_cast<int>(hi));
  });
}

void NavEnv::place(int i, const double* tiago_pose, const double* fetch_pose, const double* goal,
                   const double* fetch_goal) {
  if (i < 0 || i >= st_.N) throw std::out_of_range("NavEnv::place: env index out of range");
  nav_place(model_, st_, worlds_, buffers_, i, tiago_pose, fetch_pose, goal, fetch_goal);
}

void NavEnv::step(const double* actions) {
  const int block = model_.config.block;
  parallel_blocks(st_.N, block, [&](int64_t lo, int64_t hi) {
    NavProfile* prof = profiling_ ? &profile_[static_cast<size_t>(lo / block)] : nullptr;
    nav_step_range(model_, st_, worlds_, buffers_, actions, static_cast<int>(lo), static_cast<int>(hi), prof);
  });
}

// ---------------------------------------------------------------- profiling

std::vector<std::string> NavEnv::profile_sections() const { return {"box2d", "env"}; }

void NavEnv::set_profiling(bool on) {
  profiling_ = on;
  if (on) std::fill(profile_.begin(), profile_.end(), NavProfile{});
}

std::vector<double> NavEnv::profile_seconds() const {
  std::vector<double> s(2, 0.0);
  for (const NavProfile& p : profile_) {
    s[0] += p.box2d;
    s[1] += p.env;
  }
  return s;
}

// ---------------------------------------------------------------- ATACOM

ProjectorModel NavEnv::projector_model() const { return nav_projector_model(model_); }

void NavEnv::constraint_model(ProjectorBatch& pb, int begin, int end) const {
  nav_constraint_model(model_.geom, model_.sys, st_.tiago.data(), st_.fetch.data(), st_.fetch_vel.data(), pb, begin,
                       end);
}

// ---------------------------------------------------------------- snapshots

// Snapshot (src/core/snapshot.hpp): HEAD, NAVS (the batch and its
// streams, envs/nav/nav_batch_fields.hpp), BUFS; read into copies first so
// a refused stream leaves the env untouched.
void NavEnv::save_state(std::ostream& out) const {
  nlohmann::json j;
  to_json(j, model_.config);
  SnapshotWriter w(kTagNav, "nav");
  write_head_section(w, st_.N, snapshot_fingerprint(j.dump()));
  write_fields<NavStateFields>(w.section(NavStateFields::kTag), st_);
  write_buffers_section(w, buffers_);
  w.finish(out);
}

void NavEnv::load_state(std::istream& in) {
  nlohmann::json j;
  to_json(j, model_.config);
  SnapshotReader r(in, kTagNav, "nav");
  const int N = st_.N;
  read_head_section(r, N, snapshot_fingerprint(j.dump()));
  NavBatch s;
  s.resize(N);
  read_fields<NavStateFields>(r.section(NavStateFields::kTag, NavStateFields::kName), s);
  EnvBuffers b = buffers_;
  read_buffers_section(r, b);
  r.finish();
  st_ = std::move(s);
  buffers_.copy_values_from(b);
  // Rebuild every world from the SoA: the bodies' poses and velocities are the
  // only Box2D state a step depends on (no touching contact survives a step,
  // warm starting and sleeping are off).
  for (int i = 0; i < N; ++i) {
    worlds_.rebuild(i);
    worlds_.place(i, &st_.tiago[3 * i], &st_.fetch[3 * i]);
  }
}

}  // namespace atacom
