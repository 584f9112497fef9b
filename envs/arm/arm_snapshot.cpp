// ArmEnv snapshots in the one env snapshot format (src/core/snapshot.hpp):
// HEAD (env count, config fingerprint), ARMS (episode state and streams),
// CACH (the cached model of the current state), HUMN (HRI: the moving
// obstacle and the cup), BUFS. Read into a copy, swapped in at the end: a
// refused snapshot leaves the env as it was.
#include <istream>
#include <ostream>
#include <stdexcept>

#include "envs/arm/arm_env.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagArm = snapshot_tag("ARM ");
constexpr uint32_t kTagState = snapshot_tag("ARMS");
constexpr uint32_t kTagCache = snapshot_tag("CACH");
constexpr uint32_t kTagHuman = snapshot_tag("HUMN");

uint64_t fingerprint(const ArmEnvConfig& c) {
  nlohmann::json j;
  to_json(j, c);
  return snapshot_fingerprint(j.dump());
}
std::string env_name(const ArmModel& m) { return m.spec.name + " env"; }
}  // namespace

void ArmEnv::save_state(std::ostream& out) const {
  const ArmBatch& b = batch_;
  SnapshotWriter w(kTagArm, env_name(*model_));
  write_head_section(w, num_envs(), fingerprint(config()));
  {
    std::ostream& s = w.section(kTagState);
    bin::write_pod(s, b.seed);
    bin::write_vec(s, b.q);
    bin::write_vec(s, b.goal);
    bin::write_vec(s, b.t);
    bin::write_vec(s, b.ret);
    bin::write_vec(s, b.fallback);
    for (const Rng& r : b.rng) bin::write_rng(s, r);
  }
  {
    std::ostream& s = w.section(kTagCache);
    bin::write_vec(s, b.c);
    bin::write_vec(s, b.J);
    bin::write_vec(s, b.grasp);
    bin::write_vec(s, b.approach);
  }
  if (hri()) {
    std::ostream& s = w.section(kTagHuman);
    bin::write_vec(s, b.human.t);
    bin::write_vec(s, b.human.body.pose);
    bin::write_vec(s, b.human.body.pose_rate);
    bin::write_vec(s, b.human.body.cap);
    bin::write_vec(s, b.human.body.cap_vel);
    bin::write_vec(s, b.human.Jx);
    bin::write_vec(s, b.human.final_cap);
    bin::write_vec(s, b.cup);
    bin::write_vec(s, b.min_hd);
    bin::write_vec(s, b.spilled);
  }
  write_buffers_section(w, buffers_);
  w.finish(out);
}

void ArmEnv::load_state(std::istream& in) {
  SnapshotReader r(in, kTagArm, env_name(*model_));
  read_head_section(r, num_envs(), fingerprint(config()));
  ArmBatch b = batch_;  // same sizes; every array below is checked against them
  auto get = [](std::istream& s, auto& v, const char* what) { bin::read_vec_sized(s, v, what); };
  {
    std::istream& s = r.section(kTagState, "state");
    b.seed = bin::read_pod<uint64_t>(s, "seed");
    get(s, b.q, "q");
    get(s, b.goal, "goal");
    get(s, b.t, "t");
    get(s, b.ret, "return");
    get(s, b.fallback, "fallback");
    for (Rng& x : b.rng) bin::read_rng(s, x, "rng");
  }
  {
    std::istream& s = r.section(kTagCache, "cache");
    get(s, b.c, "c");
    get(s, b.J, "J");
    get(s, b.grasp, "grasp");
    get(s, b.approach, "approach");
  }
  if (hri()) {
    std::istream& s = r.section(kTagHuman, "human");
    get(s, b.human.t, "human.t");
    get(s, b.human.body.pose, "human.pose");
    get(s, b.human.body.pose_rate, "human.pose_rate");
    get(s, b.human.body.cap, "human.cap");
    get(s, b.human.body.cap_vel, "human.cap_vel");
    get(s, b.human.Jx, "human.Jx");
    get(s, b.human.final_cap, "human.final_cap");
    get(s, b.cup, "cup");
    get(s, b.min_hd, "min_human_distance");
    get(s, b.spilled, "spilled");
  }
  EnvBuffers bufs = buffers_;
  read_buffers_section(r, bufs);
  r.finish();
  batch_ = std::move(b);
  buffers_.copy_values_from(bufs);
}

}  // namespace atacom
