// The one env snapshot format (BatchEnv::save_state / load_state), for every
// env: tagged, sized sections in the one binary container
// (src/core/binary_container.hpp), fields written with src/core/binary_io.hpp.
//
// Layout (native endian): the container with magic "SNAP" + u32 env tag and
// one section, the body:
//   u32 "SNAP" | u32 env tag | u32 format version | u64 body bytes | body |
//   u64 FNV-1a of everything before
//   body = sections, each  u32 tag | u64 bytes | bytes
// A section's bytes are bin::write_pod / write_vec / write_rng fields. The
// reader checks magic, env, version, length and checksum before any field is
// read, then each section's tag and that its fields use exactly its bytes; a
// failure throws std::runtime_error naming the env and the section, and the
// env's state is not touched (envs read into copies and swap at the end).
// The snapshot is self-delimiting, so it can sit inside a checkpoint payload.
#pragma once
#include <cstdint>
#include <istream>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "atacom/env.hpp"
#include "src/core/binary_io.hpp"

namespace atacom {

constexpr uint32_t kSnapshotMagic = 0x50414e53;  // "SNAP"
constexpr uint32_t kSnapshotVersion = 1;

// Four ASCII characters as a tag ("ARM " -> its u32), for readable constants.
constexpr uint32_t snapshot_tag(const char (&s)[5]) {
  return uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
         uint32_t(uint8_t(s[3])) << 24;
}
std::string snapshot_tag_name(uint32_t tag);  // "ARM " for printable tags, else hex

class SnapshotWriter {
 public:
  SnapshotWriter(uint32_t env_tag, std::string env_name);
  // Starts a section; fields go to the returned stream until the next
  // section() or finish().
  std::ostream& section(uint32_t tag);
  // Writes the whole snapshot to out; throws if the stream fails.
  void finish(std::ostream& out);

 private:
  void close_section();
  uint32_t env_tag_;
  std::string env_name_;
  std::string body_;
  std::ostringstream cur_;
  uint32_t cur_tag_ = 0;
  bool open_ = false;
};

class SnapshotReader {
 public:
  // Reads and verifies one whole snapshot from in (magic, env tag, version,
  // length, checksum); env_name only words the messages.
  SnapshotReader(std::istream& in, uint32_t env_tag, std::string env_name);
  // The next section, which must carry `tag`; `what` names it in messages.
  std::istream& section(uint32_t tag, const char* what);
  // After the last section: the previous section was read exactly and no
  // section is left over.
  void finish();
  const std::string& prefix() const { return prefix_; }  // "<env> snapshot: "

 private:
  void close_section();
  std::string prefix_;
  std::string body_;
  size_t pos_ = 0;
  std::istringstream cur_;
  std::string cur_what_;
  size_t cur_size_ = 0;
  bool open_ = false;
};

// The sections every env writes, first and last:
// "HEAD": u32 env count, u64 fingerprint of the env's config (FNV-1a of its
// JSON), so a snapshot of another batch size or config is refused by name;
void write_head_section(SnapshotWriter& w, int num_envs, uint64_t config_fingerprint);
void read_head_section(SnapshotReader& r, int num_envs, uint64_t config_fingerprint);
// "BUFS": every EnvBuffers array; read into `b`, each array's size must match.
// cost_continuous comes last: snapshots of builds before it hold the
// continuous cost in the cost slot and end there; they load with that value
// as cost_continuous and cost = 1 where it is > 0 (both are rewritten by the
// next step).
void write_buffers_section(SnapshotWriter& w, const EnvBuffers& b);
void read_buffers_section(SnapshotReader& r, EnvBuffers& b);

uint64_t snapshot_fingerprint(const std::string& config_json);

}  // namespace atacom
