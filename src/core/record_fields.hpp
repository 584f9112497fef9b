// One field list per record (the idea of MuJoCo's mjxmacro.h): a record's
// fields are named once, in the order their bytes are written, and every
// consumer -- the snapshot writer and reader, value copies, hashes, counts --
// walks that one list, so a field added to the list reaches all of them.
//
// A field list is a type
//   struct FooFields {
//     using Record = Foo;
//     template <class V> static constexpr void each(V&& v) {
//       v("x", &Foo::x);                                          // a member
//       v("human.pose", [](auto& r) -> auto& { return r.h.pose; });  // a nested one
//       v("late", &Foo::late, kFieldAppended);                    // see below
//     }
//   };
// A visitor is called as v(name, accessor) or v(name, accessor, flags), so it
// takes `(const char* name, const auto& acc, unsigned flags = kFieldPlain)`.
// An accessor is a member pointer or a lambda taking the record by `auto&`;
// field_of(r, acc) gives the member with r's constness. Field types: a
// trivially copyable value, a std::vector of them (written with its count),
// or std::vector<Rng> (one state per element, no count: its size is the
// record's env count).
//
// kFieldAppended marks a field added after files with the list's earlier
// fields were written: a reader takes it only when its section has bytes
// left, and says when it was absent (read_fields returns false).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "atacom/rng.hpp"
#include "src/core/binary_io.hpp"

namespace atacom {

enum FieldFlags : unsigned {
  kFieldPlain = 0,
  kFieldAppended = 1,  // absent from files of earlier builds (read only if bytes are left)
};

template <class R, class Acc>
decltype(auto) field_of(R& r, const Acc& acc) {
  return std::invoke(acc, r);
}

namespace fields_detail {
template <class T>
struct IsVector : std::false_type {};
template <class T, class A>
struct IsVector<std::vector<T, A>> : std::true_type {};
}  // namespace fields_detail

// How many fields the list names (usable in static_assert).
template <class F>
constexpr int field_count() {
  int n = 0;
  F::each([&](const char*, const auto&, unsigned = kFieldPlain) { ++n; });
  return n;
}

// sizeof of every member the list names: a static check that a record has no
// member the list forgot, `sizeof(Foo) - field_bytes<FooFields>()` being only
// the members that are not state (an env count, scratch) and padding.
template <class F>
constexpr size_t field_bytes() {
  size_t n = 0;
  F::each([&](const char*, const auto& acc, unsigned = kFieldPlain) {
    using M = std::remove_cvref_t<decltype(field_of(std::declval<typename F::Record&>(), acc))>;
    n += sizeof(M);
  });
  return n;
}

// Writes every field, in list order, with the binary_io helpers.
template <class F>
void write_fields(std::ostream& out, const typename F::Record& r) {
  F::each([&](const char*, const auto& acc, unsigned = kFieldPlain) {
    const auto& m = field_of(r, acc);
    using M = std::remove_cvref_t<decltype(m)>;
    if constexpr (std::is_same_v<M, std::vector<Rng>>) {
      for (const Rng& x : m) bin::write_rng(out, x);
    } else if constexpr (fields_detail::IsVector<M>::value) {
      bin::write_vec(out, m);
    } else {
      bin::write_pod(out, m);
    }
  });
}

// Reads every field written by write_fields into `r`, whose vectors already
// have the sizes the input must hold (a count that differs is refused, naming
// `prefix` + the field). Returns false when kFieldAppended fields were absent
// (the input ended before them; they keep their values).
template <class F>
bool read_fields(std::istream& in, typename F::Record& r, const std::string& prefix = "") {
  bool complete = true;
  F::each([&](const char* name, const auto& acc, unsigned flags = kFieldPlain) {
    if (!complete) return;
    if (flags & kFieldAppended) {
      const bool more = in.peek() != std::char_traits<char>::eof();
      in.clear();  // a peek at the end sets eofbit, which a later tellg would read as an error
      if (!more) {
        complete = false;
        return;
      }
    }
    auto& m = field_of(r, acc);
    using M = std::remove_cvref_t<decltype(m)>;
    const std::string what = prefix + name;
    if constexpr (std::is_same_v<M, std::vector<Rng>>) {
      for (Rng& x : m) bin::read_rng(in, x, what.c_str());
    } else if constexpr (fields_detail::IsVector<M>::value) {
      bin::read_vec_sized(in, m, what.c_str());
    } else {
      m = bin::read_pod<M>(in, what.c_str());
    }
  });
  return complete;
}

// Copies every field's values from `from` into `to`'s storage (vectors must
// have the same sizes: views on to's arrays stay valid).
template <class F>
void copy_field_values(const typename F::Record& from, typename F::Record& to) {
  F::each([&](const char* name, const auto& acc, unsigned = kFieldPlain) {
    const auto& src = field_of(from, acc);
    auto& dst = field_of(to, acc);
    using M = std::remove_cvref_t<decltype(dst)>;
    if constexpr (fields_detail::IsVector<M>::value) {
      if (src.size() != dst.size()) throw std::logic_error(std::string("copy_field_values: shapes of ") + name + " differ");
      std::copy(src.begin(), src.end(), dst.begin());
    } else {
      dst = src;
    }
  });
}

}  // namespace atacom
