// Integer flags checked against the same Range as their config keys.
//
// CLI11 converts "99999999999999999999" to the type's maximum and "-1" to
// 2^64 - 1 for an unsigned target, and its range message prints a 309-digit
// bound. A flag added here is read as text, parsed whole (parse_integer:
// no wrap, no saturation, no "1e20") and range-checked, with a message that
// names the flag and the allowed range: "--steps: 99999999999999999999 is
// not an integer in [1, 10^12]". Help shows the range and the default.
#pragma once
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

template <class T>
CLI::Option* add_integer_flag(CLI::App& app, const std::string& name, T& target, const Range<T>& r,
                              const std::string& help) {
  CLI::Option* o = app.add_option_function<std::string>(
      name,
      [&target, r, name](const std::string& text) {
        const std::optional<T> v = parse_integer<T>(text);
        if (!v || !r.contains(*v))
          throw CLI::ValidationError(name, printable_text(text, 40) + " is not " + r.describe());
        target = *v;
      },
      help + " (" + r.str() + ")");
  o->type_name("INT")->default_str(std::to_string(target));
  return o;
}

// Seeds of every subcommand: what train.seed allows, so a run's seed means the same everywhere.
template <class T>
Range<T> seed_range() {
  return range::closed<T>(0, T(std::numeric_limits<int64_t>::max()));
}

}  // namespace atacom::cli
