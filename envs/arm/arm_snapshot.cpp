// ArmEnv snapshots in the one env snapshot format (src/core/snapshot.hpp):
// HEAD (env count, config fingerprint), ARMS (episode state and streams),
// CACH (the cached model of the current state), HUMN (HRI: the moving
// obstacle and the cup), BUFS; the sections' fields are the lists of
// envs/arm/arm_batch_fields.hpp. Read into a copy, swapped in at the end: a
// refused snapshot leaves the env as it was.
#include <istream>
#include <ostream>
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_batch_fields.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagArm = snapshot_tag("ARM ");

uint64_t fingerprint(const ArmEnvConfig& c) {
  nlohmann::json j;
  to_json(j, c);
  return snapshot_fingerprint(env_config_fingerprint_form(j).dump());  // snapshots of earlier builds load
}
std::string env_name(const ArmModel& m) { return m.spec.name + " env"; }
}  // namespace

void ArmEnv::save_state(std::ostream& out) const {
  SnapshotWriter w(kTagArm, env_name(*model_));
  write_head_section(w, num_envs(), fingerprint(config()));
  write_fields<ArmStateFields>(w.section(ArmStateFields::kTag), batch_);
  write_fields<ArmCacheFields>(w.section(ArmCacheFields::kTag), batch_);
  if (hri()) write_fields<ArmHumanFields>(w.section(ArmHumanFields::kTag), batch_);
  write_buffers_section(w, buffers_);
  w.finish(out);
}

namespace {
template <class F>
void read_section(SnapshotReader& r, ArmBatch& b) {
  read_fields<F>(r.section(F::kTag, F::kName), b);
}
}  // namespace

void ArmEnv::load_state(std::istream& in) {
  SnapshotReader r(in, kTagArm, env_name(*model_));
  read_head_section(r, num_envs(), fingerprint(config()));
  ArmBatch b = batch_;  // same sizes; every array below is checked against them
  read_section<ArmStateFields>(r, b);
  read_section<ArmCacheFields>(r, b);
  if (hri()) read_section<ArmHumanFields>(r, b);
  EnvBuffers bufs = buffers_;
  read_buffers_section(r, bufs);
  r.finish();
  batch_ = std::move(b);
  buffers_.copy_values_from(bufs);
}

}  // namespace atacom
