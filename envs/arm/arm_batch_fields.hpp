// The field lists of ArmBatch (envs/arm/arm_batch.hpp), one per snapshot
// section, in the order of its bytes (src/core/record_fields.hpp): they drive
// the arm snapshot's writer and reader (envs/arm/arm_snapshot.cpp). The step
// scratch (items, contact, hd) is not state and is in no list; the
// static_assert below fails when ArmBatch gains a member that is in neither.
#pragma once
#include "envs/arm/arm_batch.hpp"
#include "src/core/record_fields.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

// ARMS: the episode state and streams.
struct ArmStateFields {
  using Record = ArmBatch;
  static constexpr uint32_t kTag = snapshot_tag("ARMS");
  static constexpr const char* kName = "state";
  template <class V>
  static constexpr void each(V&& v) {
    v("seed", &ArmBatch::seed);
    v("q", &ArmBatch::q);
    v("goal", &ArmBatch::goal);
    v("t", &ArmBatch::t);
    v("return", &ArmBatch::ret);
    v("fallback", &ArmBatch::fallback);
    v("rng", &ArmBatch::rng);
  }
};

// CACH: the cached model of the current state.
struct ArmCacheFields {
  using Record = ArmBatch;
  static constexpr uint32_t kTag = snapshot_tag("CACH");
  static constexpr const char* kName = "cache";
  template <class V>
  static constexpr void each(V&& v) {
    v("c", &ArmBatch::c);
    v("J", &ArmBatch::J);
    v("grasp", &ArmBatch::grasp);
    v("approach", &ArmBatch::approach);
  }
};

// HUMN (HRI only): the moving obstacle and the cup.
struct ArmHumanFields {
  using Record = ArmBatch;
  static constexpr uint32_t kTag = snapshot_tag("HUMN");
  static constexpr const char* kName = "human";
  template <class V>
  static constexpr void each(V&& v) {
    v("human.t", [](auto& b) -> auto& { return b.human.t; });
    v("human.pose", [](auto& b) -> auto& { return b.human.body.pose; });
    v("human.pose_rate", [](auto& b) -> auto& { return b.human.body.pose_rate; });
    v("human.cap", [](auto& b) -> auto& { return b.human.body.cap; });
    v("human.cap_vel", [](auto& b) -> auto& { return b.human.body.cap_vel; });
    v("human.Jx", [](auto& b) -> auto& { return b.human.Jx; });
    v("human.final_cap", [](auto& b) -> auto& { return b.human.final_cap; });
    v("cup", &ArmBatch::cup);
    v("min_human_distance", &ArmBatch::min_hd);
    v("spilled", &ArmBatch::spilled);
  }
};

// Every member is in a list, but N, the scratch and the counts of the nested
// structs (human.body.N and their padding).
static_assert(sizeof(ArmBatch) == field_bytes<ArmStateFields>() + field_bytes<ArmCacheFields>() +
                                      field_bytes<ArmHumanFields>() + sizeof(uint64_t) /* N, padded */ +
                                      sizeof(uint64_t) /* human.body.N, padded */ +
                                      sizeof(ArmBatch::items) + sizeof(ArmBatch::contact) + sizeof(ArmBatch::hd),
              "ArmBatch has a member no snapshot field list names (or a new scratch array to list above)");

}  // namespace atacom
