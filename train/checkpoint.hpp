// Checkpoint files: versioned binary with an embedded JSON manifest, written
// atomically; the one binary container (src/core/binary_container.hpp) with
// two sections, the manifest and the payload.
//
// Layout: "ATACKPT\0" | u32 version | u64 manifest bytes | manifest (JSON) |
//         u64 payload bytes | payload | u64 FNV-1a of everything before.
// The manifest says what the payload holds (counters, sizes) so a human or a
// tool can inspect a run without parsing the payload. Writing goes to a
// temporary file in the same directory, fsync, rename over the old file, fsync
// the directory: a crash leaves either the old or the new checkpoint, never a
// mix. Reading checks magic, version, lengths and checksum and throws
// std::runtime_error naming the problem.
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom {

// 2: trainer counters gained train_violations; 3: learner payload, policy
// files; 4: the env section is the one env snapshot format (src/core/snapshot.hpp);
// 5: trainer counters gained the evaluation time and the first evaluation that
// met the quality target (time_to_target).
constexpr uint32_t kCheckpointVersion = 5;
// Policy files use the same container; their payload has not changed since
// version 4, so files of version 4 still load (train/run_policy.cpp).
constexpr uint32_t kOldestPolicyVersion = 4;

struct Checkpoint {
  nlohmann::json manifest;
  std::string payload;  // opaque bytes, written by the trainer
};

void write_checkpoint_atomic(const std::string& path, const Checkpoint& ckpt);
// Reads files of versions oldest..kCheckpointVersion (older ones are refused
// with the version and what to do).
Checkpoint read_checkpoint(const std::string& path, uint32_t oldest = kCheckpointVersion);

}  // namespace atacom
