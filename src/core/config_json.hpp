// Strict reading of config structs from JSON.
//
// Every config struct parses through a ConfigReader: get() takes the optional
// keys it knows (with a type check that names the key), number() / integer() /
// string() / at() the required ones, and finish() rejects any key that was not
// taken. So a typo in a config file is an error, never a silent default.
//
// Numbers are range-checked where they are read: get(key, v, range),
// number(key, range) and integer(key, range) reject a value outside the
// allowed Range (src/core/value_range.hpp) with a message naming the key, the
// value and the range ("config key 'sac.batch_size' is 4294967360, must be an
// integer in [1, 2^20]"). An integer that does not fit the target type is
// always an error, never wrapped or saturated, even without a range.
//
// Config text is parsed by parse_json_strict / read_json_file: duplicate keys
// and absurd nesting are rejected, and no raw input byte ever reaches an
// error message (they are escaped as \xNN).
#pragma once
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/value_range.hpp"

namespace atacom {

// ---------------------------------------------------------------- text

// `s` made safe for an error message: printable ASCII kept, every other byte
// written as \xNN (so invalid UTF-8 never reaches a JSON dump), cut after
// `max_bytes` input bytes with "...".
std::string printable_text(std::string_view s, size_t max_bytes = 200);

// A JSON value for a message: its dump, cut to a readable length.
std::string value_text(const nlohmann::json& v, size_t max_bytes = 40);

// Most nesting a config or filter line may have (a deeper document is
// rejected: printing it would recurse that deep).
constexpr int kMaxJsonDepth = 64;

// Parses JSON text, rejecting duplicate keys in any object ("duplicate key
// 'train.steps'") and nesting deeper than kMaxJsonDepth. Throws
// std::invalid_argument whose message starts with `what` and never holds raw
// input bytes.
nlohmann::json parse_json_strict(std::string_view text, const std::string& what);

// Reads and parses a JSON file (at most kMaxConfigFileBytes) with
// parse_json_strict. Clear messages for a missing file, a directory, an
// unreadable or oversized file.
constexpr size_t kMaxConfigFileBytes = size_t{64} << 20;
nlohmann::json read_json_file(const std::string& path, const std::string& what = "config file");

// "unknown config key 'train.stepz' (valid keys of 'train': env, algo, seed, ...)":
// the one message for a key a section does not have. `key_path` is the full
// dotted path, `section` the section's own; `valid` in the order to list them.
std::string unknown_key_message(const std::string& key_path, const std::string& section,
                                const std::vector<std::string>& valid);

// A JSON file of a received directory (a sweep's or a run's): base/rel read
// through no symlink, a regular file of at most max_bytes (read_below,
// src/core/fs_util.hpp), parsed with parse_json_strict. Throws
// std::invalid_argument naming the file and the reason.
nlohmann::json read_json_below(const std::string& base, const std::string& rel, const std::string& what,
                               size_t max_bytes = kMaxConfigFileBytes);

// ---------------------------------------------------------------- values

// The value of `x` as T if it is a number inside `r` (integers: an integer of
// JSON); otherwise throws std::invalid_argument "<name> is <value>, must be
// <range>" / "<name> has type <t>, must be <range>".
template <class T>
T checked_number(const nlohmann::json& x, const std::string& name, const Range<T>& r) {
  auto fail = [&](bool wrong_type) -> T {
    throw std::invalid_argument(name + (wrong_type ? std::string(" has type ") + x.type_name()
                                                   : " is " + value_text(x)) +
                                ", must be " + r.describe());
  };
  if constexpr (std::is_floating_point_v<T>) {
    if (!x.is_number()) return fail(true);
    const double v = x.get<double>();
    if (!std::isfinite(v) || !r.contains(T(v))) return fail(false);
    return T(v);
  } else {
    static_assert(std::is_integral_v<T> && !std::is_same_v<T, bool>);
    if (x.is_number_float()) return fail(false);  // 1.5, or an integer too large for 64 bits
    if (!x.is_number()) return fail(true);
    T v;
    if (x.is_number_unsigned()) {
      const uint64_t u = x.get<uint64_t>();
      if (u > static_cast<uint64_t>(std::numeric_limits<T>::max())) return fail(false);
      v = static_cast<T>(u);
    } else {
      const int64_t s = x.get<int64_t>();
      if constexpr (std::is_unsigned_v<T>) {
        if (s < 0) return fail(false);
      } else {
        if (s < int64_t(std::numeric_limits<T>::min()) || s > int64_t(std::numeric_limits<T>::max()))
          return fail(false);
      }
      v = static_cast<T>(s);
    }
    if (!r.contains(v)) return fail(false);
    return v;
  }
}

// For configs whose every key is required: throws std::invalid_argument when
// j is not an object, has a key outside `keys`, or misses one of them
// (`where` names the section in the message).
inline void require_exact_keys(const nlohmann::json& j, std::initializer_list<const char*> keys,
                               const std::string& where) {
  if (!j.is_object()) throw std::invalid_argument(where + " must be a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool known = false;
    for (const char* k : keys) known = known || it.key() == k;
    if (!known) throw std::invalid_argument("unknown key '" + printable_text(it.key()) + "' in " + where);
  }
  for (const char* k : keys)
    if (!j.contains(k)) throw std::invalid_argument("missing key '" + std::string(k) + "' in " + where);
}

class ConfigReader {
 public:
  ConfigReader(const nlohmann::json& j, std::string section) : j_(j), section_(std::move(section)) {
    if (!j_.is_object()) throw std::invalid_argument("config section '" + section_ + "' must be a JSON object");
  }

  // Optional key. Integers must fit V (never wrapped); numbers must be finite.
  template <class V>
  void get(const char* key, V& v) {
    if constexpr (std::is_arithmetic_v<V> && !std::is_same_v<V, bool>) {
      get(key, v, range::all<V>());
    } else {
      if (!asked(key)) return;
      const nlohmann::json& x = j_.at(key);
      try {
        check_type(x, v);
        v = x.get<V>();
      } catch (const nlohmann::json::exception&) {
        throw std::invalid_argument("config key '" + path(key) + "' has the wrong type (" + x.type_name() + ")");
      }
    }
  }
  // Optional number inside `r`.
  template <class V, class R>
  void get(const char* key, V& v, const Range<R>& r) {
    static_assert(std::is_arithmetic_v<V> && std::is_same_v<V, R>, "range type must match the value type");
    if (!asked(key)) return;
    v = checked_number<V>(j_.at(key), name(key), r);
  }
  // Optional list of integers, each inside `r`, with min_len..max_len entries.
  void get(const char* key, std::vector<int>& v, const Range<int>& r, size_t min_len, size_t max_len) {
    if (!asked(key)) return;
    const nlohmann::json& x = j_.at(key);
    if (!x.is_array() || x.size() < min_len || x.size() > max_len)
      throw std::invalid_argument(name(key) + " must be a list of " + std::to_string(min_len) + " to " +
                                  std::to_string(max_len) + " integers " + r.str());
    std::vector<int> out;
    for (size_t i = 0; i < x.size(); ++i)
      out.push_back(checked_number<int>(x[i], "config key '" + path(key) + "[" + std::to_string(i) + "]'", r));
    v = std::move(out);
  }

  // A nested section handled by its own from_json.
  const nlohmann::json* sub(const char* key) {
    if (!asked(key)) return nullptr;
    return &j_.at(key);
  }

  // Required keys: missing ones are errors. number() also rejects NaN/Inf.
  const nlohmann::json& at(const std::string& key) {
    if (!asked(key)) throw std::invalid_argument("missing config key '" + path(key) + "'");
    return j_.at(key);
  }
  double number(const std::string& key, const Range<double>& r = range::finite()) {
    return checked_number<double>(at(key), name(key), r);
  }
  int integer(const std::string& key) { return integer<int>(key, range::all<int>()); }
  template <class I>
  I integer(const std::string& key, const Range<I>& r) {
    return checked_number<I>(at(key), name(key), r);
  }
  std::string string(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_string()) throw std::invalid_argument(path(key) + ": expected a string");
    return v.get<std::string>();
  }
  // "section.key": the name of a nested section for its own reader.
  std::string path(const std::string& key) const { return section_ + "." + key; }
  // "config key 'section.key'": how messages name a key.
  std::string name(const std::string& key) const { return "config key '" + path(key) + "'"; }

  // Call last: rejects keys nobody asked for, listing the ones the section has.
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key())) throw std::invalid_argument(unknown_key_message(path(it.key()), section_, known_));
  }

 private:
  template <class V>
  static void check_type(const nlohmann::json& x, const V&) {
    if constexpr (std::is_same_v<V, bool>) {
      if (!x.is_boolean()) throw_type();
    } else if constexpr (std::is_same_v<V, std::string>) {
      if (!x.is_string()) throw_type();
    } else if constexpr (std::is_same_v<V, std::vector<int>>) {
      if (!x.is_array()) throw_type();
      for (const auto& e : x)
        if (!e.is_number_integer()) throw_type();
      for (const auto& e : x) checked_number<int>(e, "list entry", range::all<int>());
    }
  }
  [[noreturn]] static void throw_type() { throw nlohmann::json::type_error::create(302, "type", nullptr); }
  // Records `key` as one the section knows; true when the config holds it.
  bool asked(const std::string& key) {
    if (std::find(known_.begin(), known_.end(), key) == known_.end()) known_.push_back(key);
    if (!j_.contains(key)) return false;
    seen_.insert(key);
    return true;
  }

  const nlohmann::json& j_;
  std::string section_;
  std::set<std::string> seen_;      // keys taken from the config
  std::vector<std::string> known_;  // every key asked for, in order (the valid keys of the section)
};

}  // namespace atacom
