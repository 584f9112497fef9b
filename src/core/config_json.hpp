// Strict reading of config structs from JSON.
//
// Every config struct parses through a ConfigReader: get() takes the optional
// keys it knows (with a type check that names the key), number() / integer() /
// string() / at() the required ones, and finish() rejects any key that was not
// taken. So a typo in a config file is an error, never a silent default.
#pragma once
#include <cmath>
#include <initializer_list>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

namespace atacom {

// For configs whose every key is required: throws std::invalid_argument when
// j is not an object, has a key outside `keys`, or misses one of them
// (`where` names the section in the message).
inline void require_exact_keys(const nlohmann::json& j, std::initializer_list<const char*> keys,
                               const std::string& where) {
  if (!j.is_object()) throw std::invalid_argument(where + " must be a JSON object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool known = false;
    for (const char* k : keys) known = known || it.key() == k;
    if (!known) throw std::invalid_argument("unknown key '" + it.key() + "' in " + where);
  }
  for (const char* k : keys)
    if (!j.contains(k)) throw std::invalid_argument("missing key '" + std::string(k) + "' in " + where);
}

class ConfigReader {
 public:
  ConfigReader(const nlohmann::json& j, std::string section) : j_(j), section_(std::move(section)) {
    if (!j_.is_object()) throw std::invalid_argument("config section '" + section_ + "' must be a JSON object");
  }

  template <class V>
  void get(const char* key, V& v) {
    if (!j_.contains(key)) return;
    seen_.insert(key);
    const nlohmann::json& x = j_.at(key);
    try {
      check_type(x, v);
      v = x.get<V>();
    } catch (const nlohmann::json::exception&) {
      throw std::invalid_argument("config key '" + section_ + "." + key + "' has the wrong type (" +
                                  x.type_name() + ")");
    }
  }

  // A nested section handled by its own from_json.
  const nlohmann::json* sub(const char* key) {
    if (!j_.contains(key)) return nullptr;
    seen_.insert(key);
    return &j_.at(key);
  }

  // Required keys: missing ones are errors. number() also rejects NaN/Inf.
  const nlohmann::json& at(const std::string& key) {
    seen_.insert(key);
    if (!j_.contains(key)) throw std::invalid_argument("missing config key '" + path(key) + "'");
    return j_.at(key);
  }
  double number(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_number()) throw std::invalid_argument(path(key) + ": expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) throw std::invalid_argument(path(key) + ": must be finite");
    return x;
  }
  int integer(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_number_integer()) throw std::invalid_argument(path(key) + ": expected an integer");
    return v.get<int>();
  }
  std::string string(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_string()) throw std::invalid_argument(path(key) + ": expected a string");
    return v.get<std::string>();
  }
  // "section.key": the name of a nested section for its own reader.
  std::string path(const std::string& key) const { return section_ + "." + key; }

  // Call last: rejects keys nobody asked for.
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key()))
        throw std::invalid_argument("unknown config key '" + section_ + "." + it.key() + "'");
  }

 private:
  template <class V>
  static void check_type(const nlohmann::json& x, const V&) {
    if constexpr (std::is_same_v<V, bool>) {
      if (!x.is_boolean()) throw_type();
    } else if constexpr (std::is_integral_v<V>) {
      if (!x.is_number_integer()) throw_type();
    } else if constexpr (std::is_floating_point_v<V>) {
      if (!x.is_number()) throw_type();
    } else if constexpr (std::is_same_v<V, std::string>) {
      if (!x.is_string()) throw_type();
    } else if constexpr (std::is_same_v<V, std::vector<int>>) {
      if (!x.is_array()) throw_type();
      for (const auto& e : x)
        if (!e.is_number_integer()) throw_type();
    }
  }
  [[noreturn]] static void throw_type() { throw nlohmann::json::type_error::create(302, "type", nullptr); }

  const nlohmann::json& j_;
  std::string section_;
  std::set<std::string> seen_;
};

}  // namespace atacom
