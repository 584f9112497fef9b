// One field list per config struct, for its JSON both ways (the idea of
// MuJoCo's mjxmacro.h, as src/core/record_fields.hpp for binary records).
//
// A config's list is a function template over the struct (const when
// writing) and a visitor:
//   template <class C, class V> void foo_config_fields(C& c, V& v) {
//     v.number("dt", c.dt, range::open_closed(0.0, 1.0));
//     v.integer("horizon", c.horizon, range::closed(1, 1000));
//     v.string("slack", c.slack);
//     v.section("room", [&](auto& s) { s.number("x", c.room.x); });
//     v.object("policy", c.policy);   // a struct with its own to_json / from_json
//   }
// ConfigJsonWriter turns it into a JSON object; ConfigFieldReader reads it
// through a ConfigReader (required keys, ranges, unknown keys refused with
// the valid ones listed in the list's order). The ranges sit in the list, so
// the writer and the reader cannot disagree on a key.
#pragma once
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "src/core/config_json.hpp"
#include "src/core/value_range.hpp"

namespace atacom {

class ConfigJsonWriter {
 public:
  void number(const char* key, const double& x, const Range<double>& = range::finite()) { j_[key] = x; }
  template <class I>
  void integer(const char* key, const I& x, const Range<I>& = range::all<I>()) { j_[key] = x; }
  void string(const char* key, const std::string& x) { j_[key] = x; }
  template <class T>
  void object(const char* key, const T& x) {
    nlohmann::json sub;
    to_json(sub, x);
    j_[key] = std::move(sub);
  }
  template <class F>
  void section(const char* key, F&& f) {
    ConfigJsonWriter sub;
    f(sub);
    j_[key] = std::move(sub.j_);
  }
  nlohmann::json& json() { return j_; }

 private:
  nlohmann::json j_ = nlohmann::json::object();
};

// Reads every key as required, or (Keys::Optional) keeps the value already in
// the struct for a key the JSON leaves out (a config read over its defaults).
class ConfigFieldReader {
 public:
  enum class Keys { Required, Optional };
  explicit ConfigFieldReader(ConfigReader& r, Keys keys = Keys::Required) : r_(r), optional_(keys == Keys::Optional) {}
  void number(const char* key, double& x, const Range<double>& r = range::finite()) {
    if (optional_)
      r_.get(key, x, r);
    else
      x = r_.number(key, r);
  }
  template <class I>
  void integer(const char* key, I& x, const Range<I>& r = range::all<I>()) {
    if (optional_)
      r_.get(key, x, r);
    else
      x = r_.integer<I>(key, r);
  }
  void string(const char* key, std::string& x) { x = r_.string(key); }
  template <class T>
  void object(const char* key, T& x) { from_json(r_.at(key), x); }
  template <class F>
  void section(const char* key, F&& f) {
    ConfigReader sub(r_.at(key), r_.path(key));
    ConfigFieldReader v(sub);
    f(v);
    sub.finish();
  }

 private:
  ConfigReader& r_;
  bool optional_;
};

}  // namespace atacom
