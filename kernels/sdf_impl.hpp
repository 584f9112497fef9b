// Primitive distances written once for T = double (scalar API, ground truth)
// and T = lanes::vd (SIMD across envs). Formulas and gradient conventions are
// documented in kernels/sdf.hpp.
#pragma once
#include <cmath>

#include "kernels/sdf.hpp"
#include "kernels/lanes.hpp"

namespace atacom::sdf_impl {

using lanes::vd;
using lanes::vm;

// Scalar twins of the lane helpers, so templates compile for both types.
static inline double vmin(double a, double b) { return a < b ? a : b; }
static inline double vmax(double a, double b) { return a > b ? a : b; }
static inline double vabs(double a) { return a < 0.0 ? -a : a; }
static inline double vsqrt(double a) { return std::sqrt(a); }
static inline double vsel(bool m, double a, double b) { return m ? a : b; }
static inline bool mand(bool a, bool b) { return a && b; }
using lanes::vabs;
using lanes::vmax;
using lanes::vmin;
using lanes::vsel;
using lanes::vsqrt;
static inline vm mand(vm a, vm b) { return a & b; }

// Smallest length we divide by; below it a gradient falls back to the fixed
// direction documented in sdf.hpp.
constexpr double kTiny = 1e-300;

template <class T>
static inline T one_like(double x) { return T{} + x; }

template <class T>
static inline T sign_of(T x) { return vsel(x < 0.0, one_like<T>(-1.0), one_like<T>(1.0)); }

template <class T>
static inline T box(const Shape& s, const T* p, T* g) {
  const T dx = p[0] - s.a[0], dy = p[1] - s.a[1], dz = p[2] - s.a[2];
  const T qx = vabs(dx) - s.half[0], qy = vabs(dy) - s.half[1], qz = vabs(dz) - s.half[2];
  const T zero = T{};
  const T ox = vmax(qx, zero), oy = vmax(qy, zero), oz = vmax(qz, zero);
  const T ol = vsqrt(ox * ox + oy * oy + oz * oz);
  const T d = ol + vmin(vmax(qx, vmax(qy, qz)), zero);
  if (g) {
    const T sx = sign_of(dx), sy = sign_of(dy), sz = sign_of(dz);
    const T inv = 1.0 / vmax(ol, one_like<T>(kTiny));
    const auto out = ol > 0.0;
    const auto isx = mand(qx >= qy, qx >= qz);
    const auto isy = qy >= qz;
    g[0] = vsel(out, ox * sx * inv, vsel(isx, sx, zero));
    g[1] = vsel(out, oy * sy * inv, vsel(isx, zero, vsel(isy, sy, zero)));
    g[2] = vsel(out, oz * sz * inv, vsel(isx, zero, vsel(isy, zero, sz)));
  }
  return d;
}

template <class T>
static inline T capsule(const Shape& s, const T* p, T* g) {
  const double bx = s.b[0] - s.a[0], by = s.b[1] - s.a[1], bz = s.b[2] - s.a[2];
  const double bb = bx * bx + by * by + bz * bz;
  const double inv_bb = bb > 0.0 ? 1.0 / bb : 0.0;
  const T px = p[0] - s.a[0], py = p[1] - s.a[1], pz = p[2] - s.a[2];
  T h = (px * bx + py * by + pz * bz) * inv_bb;
  h = vmin(vmax(h, T{}), one_like<T>(1.0));
  const T vx = px - h * bx, vy = py - h * by, vz = pz - h * bz;
  const T l = vsqrt(vx * vx + vy * vy + vz * vz);
  if (g) {
    const T inv = 1.0 / vmax(l, one_like<T>(kTiny));
    const auto ok = l > 0.0;
    g[0] = vsel(ok, vx * inv, T{});
    g[1] = vsel(ok, vy * inv, T{});
    g[2] = vsel(ok, vz * inv, one_like<T>(1.0));
  }
  return l - s.radius;
}

template <class T>
static inline T cylinder_z(const Shape& s, const T* p, T* g) {
  const T dx = p[0] - s.a[0], dy = p[1] - s.a[1], dz = p[2] - s.a[2];
  const T rxy = vsqrt(dx * dx + dy * dy);
  const T qr = rxy - s.radius, qz = vabs(dz) - s.half[2];
  const T zero = T{};
  const T orr = vmax(qr, zero), oz = vmax(qz, zero);
  const T ol = vsqrt(orr * orr + oz * oz);
  const T d = ol + vmin(vmax(qr, qz), zero);
  if (g) {
    const T invr = 1.0 / vmax(rxy, one_like<T>(kTiny));
    const auto onaxis = rxy > 0.0;
    const T ux = vsel(onaxis, dx * invr, one_like<T>(1.0)), uy = vsel(onaxis, dy * invr, zero);
    const T sz = sign_of(dz);
    const T inv = 1.0 / vmax(ol, one_like<T>(kTiny));
    const auto out = ol > 0.0;
    const auto radial = qr >= qz;
    g[0] = vsel(out, orr * ux * inv, vsel(radial, ux, zero));
    g[1] = vsel(out, orr * uy * inv, vsel(radial, uy, zero));
    g[2] = vsel(out, oz * sz * inv, vsel(radial, zero, sz));
  }
  return d;
}

template <class T>
static inline T shape(const Shape& s, const T* p, T* g) {
  switch (s.type) {
    case ShapeType::Box: return box(s, p, g);
    case ShapeType::CylinderZ: return cylinder_z(s, p, g);
    case ShapeType::Sphere:
    case ShapeType::Capsule: return capsule(s, p, g);
  }
  return T{};
}

// Fold the union; blend == 0 is the exact min with the nearest gradient.
template <class T>
static inline T union_of(const Shape* shapes, int count, double blend, const T* p, T* g) {
  T gd[3] = {T{}, T{}, T{}};
  T d = shape(shapes[0], p, g);
  for (int j = 1; j < count; ++j) {
    const T dj = shape(shapes[j], p, g ? gd : nullptr);
    T h;
    if (blend > 0.0) {
      h = vmin(vmax(0.5 + (dj - d) * (0.5 / blend), T{}), one_like<T>(1.0));
      d = h * d + (1.0 - h) * dj - blend * h * (1.0 - h);
    } else {
      h = vsel(d <= dj, one_like<T>(1.0), T{});
      d = vmin(d, dj);
    }
    if (g)
      for (int r = 0; r < 3; ++r) g[r] = h * g[r] + (1.0 - h) * gd[r];
  }
  return d;
}

}  // namespace atacom::sdf_impl
