// Allowed ranges of numbers read from configs and flags, and how they read.
//
// One type for both: ConfigReader checks config keys against a Range and the
// CLI validators (src/cli/flag_checks.hpp) check flags against the same
// Range, so a key and its flag say the same thing when they are wrong:
//   "config key 'sac.batch_size' is 4294967360, must be an integer in [1, 2^20]"
//   "--steps: 99999999999999999999 is not an integer in [1, 10^12]"
// Bounds print the way a user reads them: "> 0", ">= 0", "(0, 1]",
// "[1, 2^20]"; a bound at the type's limit is left out.
#pragma once
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace atacom {

// Integers print exactly, except large powers of two or ten ("2^20", "10^12").
inline std::string readable_integer(long double v) {
  if (v < 0) {
    std::string s(1, '-');
    s += readable_integer(-v);
    return s;
  }
  if (v >= 65536) {
    int e2 = 0;
    long double p = 1;
    while (p < v) { p *= 2; ++e2; }
    if (p == v) return "2^" + std::to_string(e2);
    int e10 = 0;
    p = 1;
    while (p < v) { p *= 10; ++e10; }
    if (p == v && e10 >= 6) return "10^" + std::to_string(e10);
    if (v == 4294967295.0L) return "2^32 - 1";
    if (v == 2147483647.0L) return "2^31 - 1";
    if (v == 65535.0L) return "2^16 - 1";
    if (v == 9223372036854775807.0L) return "2^63 - 1";
  }
  char b[48];
  std::snprintf(b, sizeof(b), "%.0Lf", v);
  return b;
}

inline std::string readable_number(double v) {
  if (v == std::floor(v) && std::fabs(v) < 1e18) return readable_integer(static_cast<long double>(v));
  char b[40];
  std::snprintf(b, sizeof(b), "%.6g", v);
  return b;
}

// An interval of T (integer or floating point). Unbounded sides sit at the
// type's limits (for floating point: +-inf; NaN and inf are never inside).
template <class T>
struct Range {
  static_assert(std::is_arithmetic_v<T>);
  T lo = std::numeric_limits<T>::lowest();
  T hi = std::numeric_limits<T>::max();
  bool lo_open = false, hi_open = false;

  static constexpr bool kFloat = std::is_floating_point_v<T>;

  // Bounds worth printing: all but +-inf and the 64-bit integer limits (the
  // limits of a narrower integer say that a value must fit it).
  static constexpr bool kNarrow = !kFloat && sizeof(T) < 8;
  bool has_lo() const { return lo != std::numeric_limits<T>::lowest() || kNarrow || std::is_unsigned_v<T>; }
  bool has_hi() const { return hi != std::numeric_limits<T>::max() || kNarrow; }
  bool contains(T v) const {
    if constexpr (kFloat)
      if (!std::isfinite(v)) return false;
    if (lo_open ? !(v > lo) : !(v >= lo)) return false;
    if (hi_open ? !(v < hi) : !(v <= hi)) return false;
    return true;
  }
  // "in [1, 2^20]", ">= 0", "> 0", "in (0, 1]", "finite"
  std::string str() const {
    auto num = [](T v) {
      if constexpr (kFloat) return readable_number(double(v));
      else return readable_integer(static_cast<long double>(v));
    };
    if (has_lo() && has_hi())
      return "in " + std::string(lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + (hi_open ? ")" : "]");
    if (has_lo()) return (lo_open ? "> " : ">= ") + num(lo);
    if (has_hi()) return (hi_open ? "< " : "<= ") + num(hi);
    return kFloat ? "finite" : "any";
  }
  // What the value must be: "an integer in [1, 2^20]", "a number > 0".
  std::string describe() const {
    const std::string s = str();
    return std::string(kFloat ? "a number" : "an integer") + (s == "finite" || s == "any" ? "" : " " + s);
  }
};

// Named constructors, so call sites read like the documentation.
namespace range {
template <class T> Range<T> closed(T lo, T hi) { return {lo, hi, false, false}; }        // [lo, hi]
template <class T> Range<T> open(T lo, T hi) { return {lo, hi, true, true}; }            // (lo, hi)
template <class T> Range<T> open_closed(T lo, T hi) { return {lo, hi, true, false}; }    // (lo, hi]
template <class T> Range<T> closed_open(T lo, T hi) { return {lo, hi, false, true}; }    // [lo, hi)
template <class T> Range<T> at_least(T lo) { return {lo, std::numeric_limits<T>::max(), false, false}; }
template <class T> Range<T> above(T lo) { return {lo, std::numeric_limits<T>::max(), true, false}; }
template <class T> Range<T> at_most(T hi) { return {std::numeric_limits<T>::lowest(), hi, false, false}; }
inline Range<double> positive() { return above(0.0); }
inline Range<double> non_negative() { return at_least(0.0); }
inline Range<double> finite() { return {}; }
// The whole range of an integer type (so a value that does not fit is an error, not a wrap).
template <class T> Range<T> all() { return {}; }
}  // namespace range

// Parses a whole decimal integer (no sign for unsigned T, no spaces, no
// trailing text, no base prefix: "010" is ten, "0x10" is refused); nullopt
// when it is not one or does not fit in T.
template <class T>
std::optional<T> parse_integer(std::string_view s) {
  static_assert(std::is_integral_v<T>);
  T v{};
  if (s.size() > 1 && s.front() == '+' && s[1] >= '0' && s[1] <= '9') s.remove_prefix(1);  // never "+-5"
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  return v;
}

// Parses a whole decimal number ("0.5", "1e-3", "-2"; no hex, no spaces, no
// trailing text); nullopt when it is not one or is out of double's range
// ("1e400"). NaN and +-inf ("nan", "inf") only with allow_nonfinite.
inline std::optional<double> parse_decimal(std::string_view s, bool allow_nonfinite = false) {
  if (s.size() > 1 && s.front() == '+' && s[1] != '-' && s[1] != '+') s.remove_prefix(1);
  if (s.empty()) return std::nullopt;
  double v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v, std::chars_format::general);
  if (ec != std::errc() || p != s.data() + s.size()) return std::nullopt;
  if (!std::isfinite(v) && !allow_nonfinite) return std::nullopt;
  return v;
}

// The one parser of numeric flags (every subcommand's, src/cli/flag_checks.hpp,
// and every bench program's argv): the whole text as a decimal T inside `r`,
// else std::invalid_argument "<flag>: <text> is not <an integer in [1, 10^12]>".
// Floating point T never takes NaN or inf (Range::contains refuses them).
template <class T>
T parse_flag_value(const std::string& flag, std::string_view text, const Range<T>& r) {
  std::optional<T> v;
  if constexpr (std::is_floating_point_v<T>) {
    if (const std::optional<double> d = parse_decimal(text)) v = T(*d);
  } else {
    v = parse_integer<T>(text);
  }
  if (!v || !r.contains(*v)) {
    // The text as typed, made printable and short (no raw byte reaches a message).
    std::string shown;
    for (size_t i = 0; i < text.size() && i < 40; ++i) {
      const unsigned char c = static_cast<unsigned char>(text[i]);
      if (c >= 0x20 && c < 0x7f) {
        shown += char(c);
      } else {
        char b[8];
        std::snprintf(b, sizeof(b), "\\x%02x", c);
        shown += b;
      }
    }
    if (text.size() > 40) shown += "...";
    throw std::invalid_argument(flag + ": " + shown + " is not " + r.describe());
  }
  return *v;
}

}  // namespace atacom
