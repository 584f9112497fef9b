// The closeness the finite-difference checks of the learned fields use: an
// absolute floor plus a tolerance relative to the larger magnitude.
#pragma once
#include <algorithm>
#include <cmath>

inline bool near_abs_rel(double a, double b, double abs_tol, double rel) {
  return std::abs(a - b) <= abs_tol + rel * std::max(std::abs(a), std::abs(b));
}
