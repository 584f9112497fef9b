// Arm-vs-human rows for kLanes envs at once, and the exact segment-segment
// distance of the contact check. Formulas in kernels/human_kernels.hpp and
// docs/human.md; the distance math is written once for T = double and
// T = lanes::vd.
#pragma once
#include "kernels/human_fk_lanes.hpp"
#include "kernels/human_kernels.hpp"
#include "kernels/lanes.hpp"
#include "kernels/sdf_impl.hpp"

namespace atacom::human_impl {

using lanes::vd;
using sdf_impl::one_like;
using sdf_impl::vmax;
using sdf_impl::vmin;
using sdf_impl::vsel;
using sdf_impl::vsqrt;

// Signed distance of p to the capsule (a, b, radius) whose segment has
// squared length 1 / inv_bb (inv_bb = 0 for a sphere). n: unit direction from
// the nearest axis point to p (+z on the axis, where the distance has no
// gradient); h: that point's parameter in [0, 1].
template <class T>
static inline T capsule_distance(const T* a, const T* b, double inv_bb, double radius, const T* p, T* n, T& h) {
  const T bx = b[0] - a[0], by = b[1] - a[1], bz = b[2] - a[2];
  const T px = p[0] - a[0], py = p[1] - a[1], pz = p[2] - a[2];
  h = vmin(vmax((px * bx + py * by + pz * bz) * inv_bb, T{}), one_like<T>(1.0));
  const T vx = px - h * bx, vy = py - h * by, vz = pz - h * bz;
  const T l = vsqrt(vx * vx + vy * vy + vz * vz);
  const T inv = 1.0 / vmax(l, one_like<T>(sdf_impl::kTiny));
  const auto ok = l > 0.0;
  n[0] = vsel(ok, vx * inv, T{});
  n[1] = vsel(ok, vy * inv, T{});
  n[2] = vsel(ok, vz * inv, one_like<T>(1.0));
  return l - radius;
}

// Smooth minimum over the 16 capsules of one point: distance d, gradient g =
// dd/dp, rate ddt = dd/dt at fixed p (from the capsules' velocities), and the
// exact minimum. The fold is the polynomial smooth min of kernels/sdf.hpp
// (C1, never above the exact min, at most 15 k / 4 below it).
template <class T>
static inline T human_point_distance(const T (*A)[3], const T (*B)[3], const T (*VA)[3], const T (*VB)[3],
                                     const double* inv_bb, const double* radius, double blend, const T* p, T* g,
                                     T& ddt, T& d_exact) {
  T d{}, n[3];
  for (int c = 0; c < kHumanCapsules; ++c) {
    T h;
    const T dc = capsule_distance<T>(A[c], B[c], inv_bb[c], radius[c], p, n, h);
    // d(dc)/dt at fixed p: only the nearest axis point's motion counts (h is
    // stationary inside the segment and constant where it is clamped).
    const T vx = VA[c][0] + h * (VB[c][0] - VA[c][0]);
    const T vy = VA[c][1] + h * (VB[c][1] - VA[c][1]);
    const T vz = VA[c][2] + h * (VB[c][2] - VA[c][2]);
    const T dtc = -(n[0] * vx + n[1] * vy + n[2] * vz);
    if (c == 0) {
      d = d_exact = dc;
      g[0] = n[0];
      g[1] = n[1];
      g[2] = n[2];
      ddt = dtc;
      continue;
    }
    d_exact = vmin(d_exact, dc);
    T w;  // weight of the running minimum
    if (blend > 0.0) {
      w = vmin(vmax(0.5 + (dc - d) * (0.5 / blend), T{}), one_like<T>(1.0));
      d = w * d + (1.0 - w) * dc - blend * w * (1.0 - w);
    } else {
      w = vsel(d <= dc, one_like<T>(1.0), T{});
      d = vmin(d, dc);
    }
    for (int r = 0; r < 3; ++r) g[r] = w * g[r] + (1.0 - w) * n[r];
    ddt = w * ddt + (1.0 - w) * dtc;
  }
  return d;
}

// Squared distance between segments [p1, q1] and [p2, q2] (either may be a
// point), with the parameters s, t of the closest pair. Exact: the minimiser
// of the convex quadratic |p1 + s d1 - p2 - t d2|^2 over the unit square,
// found by clamping the unconstrained solution edge by edge.
static inline double segment_segment_distance2(const double* p1, const double* q1, const double* p2, const double* q2,
                                               double* s_out = nullptr, double* t_out = nullptr) {
  double d1[3], d2[3], r[3];
  for (int i = 0; i < 3; ++i) {
    d1[i] = q1[i] - p1[i];
    d2[i] = q2[i] - p2[i];
    r[i] = p1[i] - p2[i];
  }
  auto dot = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  auto clamp01 = [](double x) { return x < 0.0 ? 0.0 : (x > 1.0 ? 1.0 : x); };
  const double a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  constexpr double kEps = 1e-24;  // squared length below which a segment is a point
  double s = 0.0, t = 0.0;
  if (a <= kEps && e <= kEps) {
    s = t = 0.0;
  } else if (a <= kEps) {
    t = clamp01(f / e);
  } else {
    const double c = dot(d1, r);
    if (e <= kEps) {
      s = clamp01(-c / a);
    } else {
      const double b = dot(d1, d2);
      const double denom = a * e - b * b;  // >= 0; 0 when parallel
      s = denom > 0.0 ? clamp01((b * f - c * e) / denom) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = clamp01(-c / a);
      } else if (t > 1.0) {
        t = 1.0;
        s = clamp01((b - c) / a);
      }
    }
  }
  double dd = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double x = r[i] + s * d1[i] - t * d2[i];
    dd += x * x;
  }
  if (s_out) *s_out = s;
  if (t_out) *t_out = t;
  return dd;
}

}  // namespace atacom::human_impl

namespace atacom::lanes {

// Rows of P points for kLanes envs: poi (P x 3) and Jp (P x 3 x NQ) lane
// vectors (the layout of ArmFkLanes), capsules from human_fk_lanes.
template <int NQ>
static inline void human_rows_lanes(const HumanRowsConst& k, const HumanFkConst& hk, const vd (*poi)[3],
                                    const vd (*Jp)[3][NQ], const HumanCapsLanes& h, vd* c, vd (*J)[NQ], vd* dcdt,
                                    vd* d_exact) {
  for (int i = 0; i < k.num_poi; ++i) {
    vd g[3], ddt, dex;
    const vd d = human_impl::human_point_distance<vd>(h.a, h.b, h.va, h.vb, hk.cap_inv_len2, hk.cap_radius, k.blend, poi[i], g, ddt, dex);
    c[i] = k.delta[i] - d;
    dcdt[i] = -ddt;
    if (d_exact) d_exact[i] = dex;
    for (int j = 0; j < k.nq; ++j) J[i][j] = -(g[0] * Jp[i][0][j] + g[1] * Jp[i][1][j] + g[2] * Jp[i][2][j]);
  }
}

}  // namespace atacom::lanes
