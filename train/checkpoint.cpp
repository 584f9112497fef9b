#include "train/checkpoint.hpp"

#include <fstream>
#include <stdexcept>
#include <string_view>

#include "src/core/binary_container.hpp"
#include "src/core/fs_util.hpp"

namespace atacom {

namespace {

constexpr char kCheckpointMagic[8] = {'A', 'T', 'A', 'C', 'K', 'P', 'T', '\0'};

}  // namespace

void write_checkpoint_atomic(const std::string& path, const Checkpoint& ckpt) {
  ContainerWriter c(std::string_view(kCheckpointMagic, sizeof kCheckpointMagic), kCheckpointVersion);
  c.section(ckpt.manifest.dump(1));
  c.section(ckpt.payload);
  write_file_atomic(path, c.finish());  // fsyncs the directory too: the rename is durable
}

Checkpoint read_checkpoint(const std::string& path, uint32_t oldest) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open checkpoint '" + path + "'");
  ContainerReader c(f, "checkpoint '" + path + "' is ", true);
  if (c.magic() != std::string_view(kCheckpointMagic, sizeof kCheckpointMagic)) c.fail("not an atacom checkpoint");
  const uint32_t version = c.version();
  if (version < oldest)
    c.fail("format version " + std::to_string(version) + ", written by an older build; this build reads version " +
           std::to_string(oldest) + (oldest == kCheckpointVersion ? std::string(" only") : " to " + std::to_string(kCheckpointVersion)) +
           " (resume with the build that wrote it, or start the run again)");
  if (version > kCheckpointVersion)
    c.fail("format version " + std::to_string(version) + ", this build reads version " + std::to_string(kCheckpointVersion));
  c.read({{"manifest"}, {"payload"}});
  c.expect_end();
  Checkpoint ck;
  try {
    ck.manifest = nlohmann::json::parse(c.section(0));
  } catch (const nlohmann::json::exception& e) {
    c.fail(std::string("corrupt (manifest: ") + e.what() + ")");
  }
  ck.payload = c.take(1);
  return ck;
}

}  // namespace atacom
