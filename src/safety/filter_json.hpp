// Reading the fields of one `atacom filter` line (numbers, vectors, lists
// of rows, per-row values), with the messages the filter promises: each
// names the key (and index) and what was expected. Shared by both methods.
#pragma once
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/limits.hpp"

namespace atacom::filter_json {

using nlohmann::json;

[[noreturn]] inline void fail(const std::string& msg) { throw std::invalid_argument(msg); }

inline double number(const json& v, const std::string& what) {
  if (!v.is_number()) fail("'" + what + "' must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail("'" + what + "' is NaN or infinite");
  return x;
}

inline std::vector<double> vec(const json& j, const std::string& key, int expected = -1) {
  const json& v = j.at(key);
  if (!v.is_array()) fail("'" + key + "' must be an array of numbers");
  if (v.size() > size_t(limits::kFilterMaxDim))  // n, m, k, p: checked before the projector allocates
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, more than the limit of " +
         std::to_string(limits::kFilterMaxDim));
  if (expected >= 0 && static_cast<int>(v.size()) != expected)
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, expected " + std::to_string(expected));
  std::vector<double> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) out.push_back(number(v[i], key + "[" + std::to_string(i) + "]"));
  return out;
}

// rows x cols matrix given as a list of rows; returns row-major data.
inline std::vector<double> mat(const json& j, const std::string& key, int rows, int cols, const std::string& shape) {
  const json& v = j.at(key);
  if (!v.is_array()) fail("'" + key + "' must be a list of rows");
  if (static_cast<int>(v.size()) != rows)
    fail("'" + key + "' must be " + std::to_string(rows) + " x " + std::to_string(cols) + " (" + shape + "), got " +
         std::to_string(v.size()) + " rows");
  std::vector<double> out;
  out.reserve(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r) {
    const json& row = v[r];
    if (!row.is_array() || static_cast<int>(row.size()) != cols)
      fail("'" + key + "' must be " + std::to_string(rows) + " x " + std::to_string(cols) + " (" + shape + "), row " +
           std::to_string(r) + " has " + (row.is_array() ? std::to_string(row.size()) : std::string("no")) + " entries");
    for (int c = 0; c < cols; ++c)
      out.push_back(number(row[c], key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]"));
  }
  return out;
}

template <class T, class Parse>
std::vector<T> per_row(const json& j, const std::string& key, int k, T dflt, Parse parse) {
  if (!j.contains(key)) return std::vector<T>(k, dflt);
  const json& v = j.at(key);
  if (!v.is_array()) return std::vector<T>(k, parse(v, key));
  if (static_cast<int>(v.size()) != k)
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, expected one per constraint (" +
         std::to_string(k) + ") or a single value");
  std::vector<T> out;
  for (size_t i = 0; i < v.size(); ++i) out.push_back(parse(v[i], key + "[" + std::to_string(i) + "]"));
  return out;
}

}  // namespace atacom::filter_json
