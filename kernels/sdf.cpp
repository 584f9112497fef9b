#include "kernels/sdf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "kernels/sdf_impl.hpp"

namespace atacom {

namespace {
void set3(double* dst, const Eigen::Vector3d& v) {
  dst[0] = v.x();
  dst[1] = v.y();
  dst[2] = v.z();
}
}  // namespace

Shape Shape::sphere(const Eigen::Vector3d& c, double r, std::string name) {
  Shape s;
  s.type = ShapeType::Sphere;
  set3(s.a, c);
  set3(s.b, c);
  s.radius = r;
  s.name = std::move(name);
  return s;
}

Shape Shape::capsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, std::string name) {
  Shape s;
  s.type = ShapeType::Capsule;
  set3(s.a, a);
  set3(s.b, b);
  s.radius = r;
  s.name = std::move(name);
  return s;
}

Shape Shape::box(const Eigen::Vector3d& center, const Eigen::Vector3d& half, std::string name) {
  if (!(half.minCoeff() > 0.0)) throw std::invalid_argument("box '" + name + "': half extents must be > 0");
  Shape s;
  s.type = ShapeType::Box;
  set3(s.a, center);
  set3(s.half, half);
  s.name = std::move(name);
  return s;
}

Shape Shape::cylinder_z(const Eigen::Vector3d& center, double r, double half_height, std::string name) {
  if (!(r > 0.0 && half_height > 0.0)) throw std::invalid_argument("cylinder '" + name + "': sizes must be > 0");
  Shape s;
  s.type = ShapeType::CylinderZ;
  set3(s.a, center);
  s.half[2] = half_height;
  s.radius = r;
  s.name = std::move(name);
  return s;
}

double shape_distance(const Shape& s, const Eigen::Vector3d& p, Eigen::Vector3d* grad) {
  const double pp[3] = {p.x(), p.y(), p.z()};
  double g[3];
  const double d = sdf_impl::shape<double>(s, pp, grad ? g : nullptr);
  if (grad) *grad = Eigen::Vector3d(g[0], g[1], g[2]);
  return d;
}

double union_distance(const ShapeUnion& u, const Eigen::Vector3d& p, Eigen::Vector3d* grad) {
  if (u.shapes.empty()) {
    if (grad) grad->setZero();
    return std::numeric_limits<double>::infinity();
  }
  const double pp[3] = {p.x(), p.y(), p.z()};
  double g[3];
  const double d = sdf_impl::union_of<double>(u.shapes.data(), static_cast<int>(u.shapes.size()), u.blend, pp,
                                              grad ? g : nullptr);
  if (grad) *grad = Eigen::Vector3d(g[0], g[1], g[2]);
  return d;
}

double union_distance_exact(const ShapeUnion& u, const Eigen::Vector3d& p, int* nearest) {
  double best = std::numeric_limits<double>::infinity();
  int arg = -1;
  for (size_t j = 0; j < u.shapes.size(); ++j) {
    const double d = shape_distance(u.shapes[j], p);
    if (d < best) {
      best = d;
      arg = static_cast<int>(j);
    }
  }
  if (nearest) *nearest = arg;
  return best;
}

double segment_distance(const Shape& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len = ab.norm();
  auto f = [&](double t) { return shape_distance(s, a + t * ab); };
  if (len == 0.0) return f(0.0);
  // Golden-section search on the convex f over [0, 1] until the bracket is
  // 1e-9 m long; f is len-Lipschitz in t, so the value error is below that.
  constexpr double kInvPhi = 0.6180339887498949;
  double lo = 0.0, hi = 1.0;
  double x1 = hi - kInvPhi * (hi - lo), x2 = lo + kInvPhi * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  while ((hi - lo) * len > 1e-9) {
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kInvPhi * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kInvPhi * (hi - lo);
      f2 = f(x2);
    }
  }
  return std::min({f(0.0), f(1.0), f1, f2});
}

bool segment_clear(const Shape& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  const Eigen::Vector3d ab = b - a;
  const double len = ab.norm();
  auto f = [&](double t) { return shape_distance(s, a + t * ab); };
  const double fm = f(0.5);
  if (fm - 0.5 * len >= r) return true;  // every point is within len/2 of the midpoint
  if (fm < r) return false;
  if (len == 0.0) return true;
  constexpr double kInvPhi = 0.6180339887498949;
  double lo = 0.0, hi = 1.0;
  double x1 = hi - kInvPhi * (hi - lo), x2 = lo + kInvPhi * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  if (std::min({f1, f2, f(0.0), f(1.0)}) < r) return false;
  while ((hi - lo) * len > 1e-9) {
    // The convex f has its minimum in [lo, hi]; it is at least
    // min(f1, f2) - len * (hi - lo) there.
    if (std::min(f1, f2) - len * (hi - lo) >= r) return true;
    if (f1 <= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kInvPhi * (hi - lo);
      f1 = f(x1);
      if (f1 < r) return false;
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kInvPhi * (hi - lo);
      f2 = f(x2);
      if (f2 < r) return false;
    }
  }
  return std::min(f1, f2) >= r;
}

double smooth_min(double a, double b, double k, double* wa) {
  double h = k > 0.0 ? std::clamp(0.5 + 0.5 * (b - a) / k, 0.0, 1.0) : (a <= b ? 1.0 : 0.0);
  if (wa) *wa = h;
  return k > 0.0 ? h * a + (1.0 - h) * b - k * h * (1.0 - h) : std::min(a, b);
}

}  // namespace atacom
