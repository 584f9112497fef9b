// Strict reading of the nav env's JSON configs: every key must be present,
// no unknown key is accepted, numbers must be finite. Errors name the key.
#pragma once
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom::nav_json {

class Reader {
 public:
  Reader(const nlohmann::json& j, std::string where) : j_(j), where_(std::move(where)) {
    if (!j_.is_object()) throw std::invalid_argument(where_ + ": expected a JSON object");
  }
  const nlohmann::json& at(const std::string& key) {
    seen_.insert(key);
    if (!j_.contains(key)) throw std::invalid_argument(where_ + ": missing key '" + key + "'");
    return j_.at(key);
  }
  double number(const std::string& key) {
    const auto& v = at(key);
    if (!v.is_number()) throw std::invalid_argument(where_ + "." + key + ": expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) throw std::invalid_argument(where_ + "." + key + ": must be finite");
    return x;
  }
  int integer(const std::string& key) {
    const auto& v = at(key);
    if (!v.is_number_integer()) throw std::invalid_argument(where_ + "." + key + ": expected an integer");
    return v.get<int>();
  }
  std::string string(const std::string& key) {
    const auto& v = at(key);
    if (!v.is_string()) throw std::invalid_argument(where_ + "." + key + ": expected a string");
    return v.get<std::string>();
  }
  std::string path(const std::string& key) const { return where_ + "." + key; }
  // Call last: rejects keys nobody asked for.
  void finish() const {
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!seen_.count(it.key())) throw std::invalid_argument(where_ + ": unknown key '" + it.key() + "'");
  }

 private:
  const nlohmann::json& j_;
  std::string where_;
  std::set<std::string> seen_;
};

}  // namespace atacom::nav_json
