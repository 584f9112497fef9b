// A figure that may be missing: NaN in memory, null in JSON (which has no NaN
// or infinity).
#pragma once
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

namespace atacom {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// v, or null when v is not finite.
inline nlohmann::json jnum(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace atacom
