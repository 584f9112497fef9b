#include "src/core/snapshot.hpp"

#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "src/core/binary_container.hpp"
#include "src/core/env_buffer_fields.hpp"

namespace atacom {

std::string snapshot_tag_name(uint32_t tag) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((tag >> (8 * i)) & 0xff);
    if (c < 0x20 || c > 0x7e) {
      char hex[16];
      std::snprintf(hex, sizeof hex, "0x%08x", tag);
      return hex;
    }
    s += c;
  }
  return "'" + s + "'";
}

SnapshotWriter::SnapshotWriter(uint32_t env_tag, std::string env_name)
    : env_tag_(env_tag), env_name_(std::move(env_name)) {}

std::ostream& SnapshotWriter::section(uint32_t tag) {
  close_section();
  cur_.str(std::string());
  cur_.clear();
  cur_tag_ = tag;
  open_ = true;
  return cur_;
}

void SnapshotWriter::close_section() {
  if (!open_) return;
  const std::string bytes = cur_.str();
  std::ostringstream head;
  bin::write_tag(head, cur_tag_);
  bin::write_pod<uint64_t>(head, bytes.size());
  body_ += head.str();
  body_ += bytes;
  open_ = false;
}

namespace {
// The container's magic of a snapshot: "SNAP" and the env's tag.
std::string snapshot_magic(uint32_t env_tag) {
  std::string m(kContainerMagicBytes, '\0');
  std::memcpy(m.data(), &kSnapshotMagic, 4);
  std::memcpy(m.data() + 4, &env_tag, 4);
  return m;
}
}  // namespace

void SnapshotWriter::finish(std::ostream& out) {
  close_section();
  ContainerWriter c(snapshot_magic(env_tag_), kSnapshotVersion);
  c.section(body_);
  const std::string bytes = c.finish();
  out.write(bytes.data(), std::streamsize(bytes.size()));
  if (!out) throw std::runtime_error(env_name_ + " snapshot: write failed");
}

SnapshotReader::SnapshotReader(std::istream& in, uint32_t env_tag, std::string env_name)
    : prefix_(std::move(env_name) + " snapshot: ") {
  ContainerReader c(in, prefix_, true);
  uint32_t magic, tag;
  std::memcpy(&magic, c.magic().data(), 4);
  std::memcpy(&tag, c.magic().data() + 4, 4);
  if (magic != kSnapshotMagic) c.fail("not an env snapshot (magic " + snapshot_tag_name(magic) + ")");
  if (tag != env_tag) c.fail("holds env " + snapshot_tag_name(tag) + ", this env is " + snapshot_tag_name(env_tag));
  if (c.version() != kSnapshotVersion)
    c.fail("format version " + std::to_string(c.version()) + ", this build reads version " +
           std::to_string(kSnapshotVersion));
  c.read({{"body"}});
  body_ = c.take(0);
}

void SnapshotReader::close_section() {
  if (!open_) return;
  open_ = false;
  const auto used = cur_.tellg();
  if (used < 0 || size_t(used) != cur_size_ || cur_.peek() != std::char_traits<char>::eof())
    throw std::runtime_error(prefix_ + "section " + cur_what_ + " has " + std::to_string(cur_size_) +
                             " bytes, this build reads " + std::to_string(used < 0 ? 0 : size_t(used)) +
                             " of them (a different layout)");
}

std::istream& SnapshotReader::section(uint32_t tag, const char* what) {
  close_section();
  if (body_.size() - pos_ < 12) throw std::runtime_error(prefix_ + "section " + what + " is missing");
  uint32_t t;
  uint64_t n;
  std::memcpy(&t, body_.data() + pos_, 4);
  std::memcpy(&n, body_.data() + pos_ + 4, 8);
  pos_ += 12;
  if (t != tag)
    throw std::runtime_error(prefix_ + "expected section " + what + " (" + snapshot_tag_name(tag) + "), found " +
                             snapshot_tag_name(t));
  if (n > body_.size() - pos_) throw std::runtime_error(prefix_ + "section " + what + " runs past the snapshot's end");
  cur_.str(body_.substr(pos_, n));
  cur_.clear();
  pos_ += n;
  cur_what_ = what;
  cur_size_ = n;
  open_ = true;
  return cur_;
}

void SnapshotReader::finish() {
  close_section();
  if (pos_ != body_.size()) throw std::runtime_error(prefix_ + "holds sections this build does not read");
}

namespace {
constexpr uint32_t kTagHead = snapshot_tag("HEAD");
constexpr uint32_t kTagBuffers = snapshot_tag("BUFS");
}  // namespace

uint64_t snapshot_fingerprint(const std::string& config_json) {
  return bin::fnv1a(config_json.data(), config_json.size());
}

void write_head_section(SnapshotWriter& w, int num_envs, uint64_t config_fingerprint) {
  std::ostream& s = w.section(kTagHead);
  bin::write_pod<int32_t>(s, num_envs);
  bin::write_pod<uint64_t>(s, config_fingerprint);
}

void read_head_section(SnapshotReader& r, int num_envs, uint64_t config_fingerprint) {
  std::istream& s = r.section(kTagHead, "head");
  const int32_t n = bin::read_pod<int32_t>(s, "env count");
  const uint64_t f = bin::read_pod<uint64_t>(s, "config fingerprint");
  if (n != num_envs)
    throw std::runtime_error(r.prefix() + "holds " + std::to_string(n) + " envs, this env has " +
                             std::to_string(num_envs));
  if (f != config_fingerprint) throw std::runtime_error(r.prefix() + "saved with a different env config");
}

void write_buffers_section(SnapshotWriter& w, const EnvBuffers& b) {
  write_fields<EnvBufferFields>(w.section(kTagBuffers), b);
}

void read_buffers_section(SnapshotReader& r, EnvBuffers& b) {
  std::istream& s = r.section(kTagBuffers, "buffers");
  if (!read_fields<EnvBufferFields>(s, b, "buffers.")) {
    // A snapshot of an earlier build: its cost slot held the continuous cost.
    for (size_t i = 0; i < b.cost.size(); ++i) {
      b.cost_continuous[i] = b.cost[i];
      b.cost[i] = b.cost[i] > 0.0f ? 1.0f : 0.0f;
    }
  }
}

}  // namespace atacom
