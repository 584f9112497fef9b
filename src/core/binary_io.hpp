// Little helpers for the binary snapshot formats (env state, checkpoints).
//
// Plain native-endian dumps of PODs and vectors, each vector prefixed by its
// element count. Every read checks the stream and throws std::runtime_error
// with the field name, so a truncated or foreign file gives a clear message
// instead of garbage state.
#pragma once
#include <algorithm>
#include <cstdint>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "atacom/rng.hpp"

namespace atacom::bin {

template <class T>
void write_pod(std::ostream& out, const T& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

template <class T>
T read_pod(std::istream& in, const char* what) {
  static_assert(std::is_trivially_copyable_v<T>);
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof(T));
  if (!in || in.gcount() != static_cast<std::streamsize>(sizeof(T)))
    throw std::runtime_error(std::string("snapshot truncated while reading ") + what);
  return v;
}

template <class T, class Alloc>
void write_vec(std::ostream& out, const std::vector<T, Alloc>& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  write_pod<uint64_t>(out, v.size());
  if (!v.empty()) out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
}

// Reads a vector written by write_vec. expected_size >= 0 enforces the count
// (a snapshot of another shape is rejected rather than silently resized).
template <class T, class Alloc>
void read_vec(std::istream& in, std::vector<T, Alloc>& v, const char* what, int64_t expected_size = -1) {
  static_assert(std::is_trivially_copyable_v<T>);
  const uint64_t n = read_pod<uint64_t>(in, what);
  if (expected_size >= 0 && n != static_cast<uint64_t>(expected_size))
    throw std::runtime_error(std::string("snapshot field ") + what + " has " + std::to_string(n) +
                             " elements, expected " + std::to_string(expected_size));
  if (n > (uint64_t{1} << 40) / sizeof(T))
    throw std::runtime_error(std::string("snapshot field ") + what + " has an implausible size");
  // Grown in 16 MiB steps as the bytes arrive: a count the input does not
  // back (a hostile checkpoint) ends in "truncated", never in a huge allocation.
  const size_t step = std::max<size_t>(1, (size_t{16} << 20) / sizeof(T));
  v.clear();
  while (v.size() < n) {
    const size_t old = v.size(), take = std::min<size_t>(step, static_cast<size_t>(n) - old);
    v.resize(old + take);
    in.read(reinterpret_cast<char*>(v.data() + old), static_cast<std::streamsize>(take * sizeof(T)));
    if (!in || in.gcount() != static_cast<std::streamsize>(take * sizeof(T)))
      throw std::runtime_error(std::string("snapshot truncated while reading ") + what);
  }
}

// Reads a vector into `v`, which already has the size the snapshot must hold
// (a batch array sized for this env): a count that differs is refused.
template <class T, class Alloc>
void read_vec_sized(std::istream& in, std::vector<T, Alloc>& v, const char* what) {
  read_vec(in, v, what, static_cast<int64_t>(v.size()));
}

// Section tags make a misaligned read fail at the first wrong section.
inline void write_tag(std::ostream& out, uint32_t tag) { write_pod(out, tag); }
inline void expect_tag(std::istream& in, uint32_t tag, const char* what) {
  const uint32_t t = read_pod<uint32_t>(in, what);
  if (t != tag) throw std::runtime_error(std::string("snapshot section ") + what + " is missing or corrupt");
}

// Rng state field by field (the struct has padding, whose bytes are not ours to hash).
inline void write_rng(std::ostream& out, const Rng& r) {
  const Rng::State st = r.state();
  for (uint64_t w : st.s) write_pod(out, w);
  write_pod(out, st.spare);
  write_pod(out, st.has_spare);
}
inline void read_rng(std::istream& in, Rng& r, const char* what) {
  Rng::State st{};
  for (auto& w : st.s) w = read_pod<uint64_t>(in, what);
  st.spare = read_pod<double>(in, what);
  st.has_spare = read_pod<uint8_t>(in, what);
  r.set_state(st);
}

// FNV-1a 64-bit over bytes: cheap integrity check for whole files. Pass the
// previous value as h to hash pieces in turn.
inline constexpr uint64_t kFnv1aSeed = 0xcbf29ce484222325ull;
inline uint64_t fnv1a(const void* data, size_t n, uint64_t h = kFnv1aSeed) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) { h ^= p[i]; h *= 0x100000001b3ull; }
  return h;
}

}  // namespace atacom::bin
