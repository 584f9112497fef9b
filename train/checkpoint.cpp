#include "train/checkpoint.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/fs_util.hpp"

namespace atacom {

namespace {

constexpr char kMagic[8] = {'A', 'T', 'A', 'C', 'K', 'P', 'T', '\0'};

}  // namespace

void write_checkpoint_atomic(const std::string& path, const Checkpoint& ckpt) {
  std::ostringstream s;
  s.write(kMagic, sizeof(kMagic));
  bin::write_pod<uint32_t>(s, kCheckpointVersion);
  const std::string manifest = ckpt.manifest.dump(1);
  bin::write_pod<uint64_t>(s, manifest.size());
  s.write(manifest.data(), std::streamsize(manifest.size()));
  bin::write_pod<uint64_t>(s, ckpt.payload.size());
  s.write(ckpt.payload.data(), std::streamsize(ckpt.payload.size()));
  std::string bytes = s.str();
  const uint64_t h = bin::fnv1a(bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&h), sizeof(h));
  write_file_atomic(path, bytes);  // fsyncs the directory too: the rename is durable
}

Checkpoint read_checkpoint(const std::string& path, uint32_t oldest) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open checkpoint '" + path + "'");
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::string bad = "checkpoint '" + path + "' is ";
  const size_t header = sizeof(kMagic) + 4 + 8;
  if (bytes.size() < header + 8 + 8) throw std::runtime_error(bad + "truncated (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) throw std::runtime_error(bad + "not an atacom checkpoint");
  uint32_t version;
  std::memcpy(&version, bytes.data() + sizeof(kMagic), 4);
  if (version < oldest)
    throw std::runtime_error(bad + "format version " + std::to_string(version) + ", written by an older build; this build reads version " +
                             std::to_string(oldest) + (oldest == kCheckpointVersion ? std::string(" only") : " to " + std::to_string(kCheckpointVersion)) +
                             " (resume with the build that wrote it, or start the run again)");
  if (version > kCheckpointVersion)
    throw std::runtime_error(bad + "format version " + std::to_string(version) + ", this build reads version " +
                             std::to_string(kCheckpointVersion));
  uint64_t mlen;
  std::memcpy(&mlen, bytes.data() + sizeof(kMagic) + 4, 8);
  if (mlen > bytes.size() - header - 16) throw std::runtime_error(bad + "truncated (manifest cut short)");
  uint64_t plen;
  std::memcpy(&plen, bytes.data() + header + mlen, 8);
  const uint64_t expect = header + mlen + 8 + plen + 8;
  if (plen > bytes.size() || expect != bytes.size())
    throw std::runtime_error(bad + (bytes.size() < expect ? "truncated" : "longer than its header says") + " (" +
                             std::to_string(bytes.size()) + " bytes, expected " + std::to_string(expect) + ")");
  uint64_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
  if (bin::fnv1a(bytes.data(), bytes.size() - 8) != stored)
    throw std::runtime_error(bad + "corrupt (checksum mismatch)");
  Checkpoint c;
  try {
    c.manifest = nlohmann::json::parse(bytes.begin() + long(header), bytes.begin() + long(header + mlen));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(bad + "corrupt (manifest: " + e.what() + ")");
  }
  c.payload = bytes.substr(header + mlen + 8, plen);
  return c;
}

}  // namespace atacom
