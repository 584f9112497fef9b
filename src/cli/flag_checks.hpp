// Numeric flags checked against the same Range as their config keys.
//
// CLI11 converts "99999999999999999999" to the type's maximum, "-1" to
// 2^64 - 1 for an unsigned target, "010" to 8 (octal) and "0x10" to 16, and
// turns "nan" into a silent default after a range check; its range message
// prints a 309-digit bound. Every numeric flag of every subcommand is added
// here instead: read as text and parsed by the one parser
// (parse_flag_value, src/core/value_range.hpp: decimal only, the whole
// text, no wrap, no saturation, no NaN/inf) and range-checked, with a
// message that names the flag and the allowed range: "--steps:
// 99999999999999999999 is not an integer in [1, 10^12]". Help shows the
// range and the default. A wrong value is a usage error: exit code 2.
#pragma once
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "atacom/safety_layer.hpp"
#include "src/core/config_json.hpp"
#include "src/core/value_range.hpp"

namespace atacom::cli {

// "none | atacom | safelayer ...": the safety table's names, for --safety help texts.
inline std::string safety_choices() {
  std::string s;
  for (const std::string& n : safety_layer_names()) s += (s.empty() ? "" : " | ") + n;
  return s;
}

namespace detail {
template <class T>
std::string default_text(T v) {
  if constexpr (std::is_floating_point_v<T>) {
    char b[32];
    std::snprintf(b, sizeof(b), "%g", double(v));
    return b;
  } else {
    return std::to_string(v);
  }
}
}  // namespace detail

// A numeric flag (integer or floating point T). `target` keeps its value
// unless the flag is given; `set`, when not null, becomes true when it is.
template <class T>
CLI::Option* add_number_flag(CLI::App& app, const std::string& name, T& target, const Range<T>& r,
                             const std::string& help, bool* set = nullptr) {
  CLI::Option* o = app.add_option_function<std::string>(
      name,
      [&target, r, name, set](const std::string& text) {
        try {
          target = parse_flag_value<T>(name, text, r);
        } catch (const std::invalid_argument& e) {
          // CLI11 prefixes the option name itself: give it the rest of the message.
          const std::string m = e.what();
          throw CLI::ValidationError(name, m.substr(name.size() + 2));
        }
        if (set) *set = true;
      },
      help + " (" + r.str() + ")");
  // A flag that only overrides when given (`set`) has no default of its own to show.
  o->type_name(std::is_floating_point_v<T> ? "NUMBER" : "INT")->default_str(set ? "" : detail::default_text(target));
  return o;
}

template <class T>
CLI::Option* add_integer_flag(CLI::App& app, const std::string& name, T& target, const Range<T>& r,
                              const std::string& help) {
  static_assert(std::is_integral_v<T>);
  return add_number_flag(app, name, target, r, help);
}

// Seeds of every subcommand: what train.seed allows, so a run's seed means the same everywhere.
template <class T>
Range<T> seed_range() {
  return range::closed<T>(0, T(std::numeric_limits<int64_t>::max()));
}

}  // namespace atacom::cli
