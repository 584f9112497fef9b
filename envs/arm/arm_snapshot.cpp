// ArmEnv snapshots: every per-env state vector and RNG stream; the cached
// model is recomputed from q on load (a pure function of q, so bit-identical).
#include <istream>
#include <ostream>
#include <stdexcept>

#include "envs/arm/arm_env.hpp"

namespace atacom {

void ArmEnv::save_state(std::ostream& out) const {
  const ArmBatch& b = batch_;
  const int32_t N = num_envs();
  out.write(reinterpret_cast<const char*>(&N), sizeof N);
  out.write(reinterpret_cast<const char*>(&b.seed), sizeof b.seed);
  auto put = [&](const auto& v) { out.write(reinterpret_cast<const char*>(v.data()), sizeof(v[0]) * v.size()); };
  put(b.q);
  put(b.goal);
  put(b.t);
  put(b.ret);
  put(b.fallback);
  for (const Rng& r : b.rng) {
    const Rng::State st = r.state();
    out.write(reinterpret_cast<const char*>(&st), sizeof st);
  }
  put(b.c);
  put(b.J);
  put(b.grasp);
  put(b.approach);
  if (hri()) {
    put(b.human.body.pose);
    put(b.human.body.pose_rate);
    put(b.human.body.cap);
    put(b.human.body.cap_vel);
    put(b.human.t);
    put(b.human.Jx);
    put(b.cup);
    put(b.min_hd);
    put(b.spilled);
  }
  put(buffers_.obs);
}

void ArmEnv::load_state(std::istream& in) {
  ArmBatch& b = batch_;
  int32_t N = 0;
  in.read(reinterpret_cast<char*>(&N), sizeof N);
  if (!in || N != num_envs())
    throw std::runtime_error("arm env snapshot holds " + std::to_string(N) + " envs, this env has " +
                             std::to_string(num_envs()));
  in.read(reinterpret_cast<char*>(&b.seed), sizeof b.seed);
  auto get = [&](auto& v) { in.read(reinterpret_cast<char*>(v.data()), sizeof(v[0]) * v.size()); };
  get(b.q);
  get(b.goal);
  get(b.t);
  get(b.ret);
  get(b.fallback);
  for (Rng& r : b.rng) {
    Rng::State st;
    in.read(reinterpret_cast<char*>(&st), sizeof st);
    r.set_state(st);
  }
  get(b.c);
  get(b.J);
  get(b.grasp);
  get(b.approach);
  if (hri()) {
    get(b.human.body.pose);
    get(b.human.body.pose_rate);
    get(b.human.body.cap);
    get(b.human.body.cap_vel);
    get(b.human.t);
    get(b.human.Jx);
    get(b.cup);
    get(b.min_hd);
    get(b.spilled);
  }
  get(buffers_.obs);
  if (!in) throw std::runtime_error("arm env snapshot is truncated");
}

}  // namespace atacom
