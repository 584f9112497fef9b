#include "src/core/binary_container.hpp"

#include <algorithm>
#include <stdexcept>

#include "src/core/binary_io.hpp"

namespace atacom {

namespace {
constexpr size_t kReadStep = size_t{16} << 20;  // buffers grow by at most this per read
}  // namespace

ContainerWriter::ContainerWriter(std::string_view magic, std::optional<uint32_t> version) {
  if (magic.size() != kContainerMagicBytes) throw std::logic_error("ContainerWriter: the magic must be 8 bytes");
  bytes_.assign(magic);
  if (version) bytes_.append(reinterpret_cast<const char*>(&*version), sizeof(uint32_t));
}

void ContainerWriter::section(std::string_view bytes, size_t element_size) {
  if (element_size == 0 || bytes.size() % element_size != 0)
    throw std::logic_error("ContainerWriter: a section's bytes must be whole elements");
  const uint64_t count = bytes.size() / element_size;
  bytes_.append(reinterpret_cast<const char*>(&count), sizeof count);
  bytes_.append(bytes);
}

std::string ContainerWriter::finish() const {
  std::string out = bytes_;
  const uint64_t sum = bin::fnv1a(out.data(), out.size());
  out.append(reinterpret_cast<const char*>(&sum), sizeof sum);
  return out;
}

ContainerReader::ContainerReader(std::istream& in, std::string prefix, bool versioned)
    : in_(in), prefix_(std::move(prefix)), sum_(bin::kFnv1aSeed) {
  read_exact(magic_, kContainerMagicBytes, "header");
  if (versioned) {
    std::string v;
    read_exact(v, sizeof(uint32_t), "header");
    std::copy(v.begin(), v.end(), reinterpret_cast<char*>(&version_));
  }
}

void ContainerReader::fail(const std::string& why) const { throw std::runtime_error(prefix_ + why); }

// Reads n bytes into out (hashing them), in bounded steps.
void ContainerReader::read_exact(std::string& out, uint64_t n, const std::string& what) {
  out.clear();
  while (out.size() < n) {
    const size_t old = out.size(), take = size_t(std::min<uint64_t>(kReadStep, n - old));
    out.resize(old + take);
    in_.read(out.data() + old, std::streamsize(take));
    const size_t got = size_t(in_.gcount());
    if (got != take) {
      if (n <= kContainerMagicBytes + sizeof(uint64_t)) fail("truncated (" + what + ")");
      fail("truncated (" + what + ": " + std::to_string(old + got) + " of " + std::to_string(n) + " bytes)");
    }
  }
  sum_ = bin::fnv1a(out.data(), out.size(), sum_);
}

void ContainerReader::read(const std::vector<ContainerSection>& sections) {
  sections_.assign(sections.size(), std::string());
  std::string count_bytes;
  for (size_t i = 0; i < sections.size(); ++i) {
    const std::string name = std::string("section ") + sections[i].name;
    read_exact(count_bytes, sizeof(uint64_t), name + " length");
    uint64_t count = 0;
    std::copy(count_bytes.begin(), count_bytes.end(), reinterpret_cast<char*>(&count));
    const size_t es = sections[i].element_size;
    if (count > (uint64_t{1} << 40) / es) fail("truncated or corrupt (" + name + " claims " + std::to_string(count) + " elements)");
    read_exact(sections_[i], count * es, name);
  }
  uint64_t stored = 0;
  in_.read(reinterpret_cast<char*>(&stored), sizeof stored);
  if (in_.gcount() != std::streamsize(sizeof stored)) fail("truncated (checksum missing)");
  if (stored != sum_) fail("corrupt (checksum mismatch)");
}

void ContainerReader::expect_end() {
  if (in_.peek() != std::char_traits<char>::eof()) fail("longer than its header says (bytes after the checksum)");
  in_.clear();
}

}  // namespace atacom
