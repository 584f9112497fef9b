// The one binary container of checkpoints and policy files (train/
// checkpoint.hpp), env snapshots (src/core/snapshot.hpp) and learned-SDF
// weight files (src/core/redsdf_model.hpp):
//
//   magic (8 bytes) | u32 version (unless the magic holds it) |
//   sections, each  u64 count | count x element bytes |
//   u64 FNV-1a of every byte before it
//
// (native endian). A format names its sections in order, with their element
// size (1: raw bytes; 4: a float array); the names word the messages. The
// reader takes the magic and version first (so a foreign file or another
// version is named as such), then every section and the checksum, growing
// its buffers in bounded steps as bytes arrive (a length the input does not
// back ends in "truncated", never in a huge allocation), and hands out no
// section before the checksum holds. Every failure throws
// std::runtime_error(prefix + why). The container is self-delimiting, so a
// snapshot can sit inside a checkpoint's payload.
#pragma once
#include <cstddef>
#include <cstdint>
#include <istream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace atacom {

constexpr size_t kContainerMagicBytes = 8;

struct ContainerSection {
  const char* name;        // for messages ("manifest", "payload", "parameters")
  size_t element_size = 1;  // the count prefix counts elements of this many bytes
};

class ContainerWriter {
 public:
  // magic: exactly 8 bytes; version: written after it when set.
  ContainerWriter(std::string_view magic, std::optional<uint32_t> version);
  // Appends a section: u64 (bytes.size() / element_size) | bytes.
  void section(std::string_view bytes, size_t element_size = 1);
  // The container's bytes, checksum appended.
  std::string finish() const;

 private:
  std::string bytes_;
};

class ContainerReader {
 public:
  // Reads the magic and (when versioned) the version from `in`; a stream
  // that ends first is "truncated (header)".
  ContainerReader(std::istream& in, std::string prefix, bool versioned);
  const std::string& magic() const { return magic_; }
  uint32_t version() const { return version_; }
  // Reads the sections, in order, and the checksum; throws for a short
  // input or a checksum mismatch.
  void read(const std::vector<ContainerSection>& sections);
  // Section i's bytes (without its count), after read().
  const std::string& section(size_t i) const { return sections_.at(i); }
  std::string take(size_t i) { return std::move(sections_.at(i)); }
  // For a whole file: no byte may follow the checksum.
  void expect_end();
  [[noreturn]] void fail(const std::string& why) const;
  const std::string& prefix() const { return prefix_; }

 private:
  void read_exact(std::string& out, uint64_t n, const std::string& what);
  std::istream& in_;
  std::string prefix_;
  uint64_t sum_;  // FNV-1a of every byte read so far
  std::string magic_;
  uint32_t version_ = 0;
  std::vector<std::string> sections_;
};

}  // namespace atacom
