// Exact signed distance fields of primitives and their unions.
//
// Primitives: sphere, capsule, axis-aligned box, vertical cylinder. Each
// returns the exact signed distance (negative inside) and its gradient, a
// unit vector wherever the distance is differentiable. Where it is not (the
// medial set inside a box or cylinder, the axis of a capsule) the gradient is
// a fixed one-sided choice: inside a box, the axis of the nearest face (x
// before y before z on ties); on a capsule's axis or a sphere's centre, +z.
//
// Unions and their seams. A union's exact distance is min_j d_j, which has a
// kink wherever two primitives are equally near. ATACOM linearises each
// constraint row once per step, so at such a seam the row would only see the
// primitive that happens to be nearest and let the arm move towards the other
// one at full speed for one step. With blend > 0 the union uses the C1
// polynomial smooth minimum, folded over the primitives:
//     h = clamp(1/2 + (b - a) / (2 k), 0, 1),
//     smin(a, b) = h a + (1 - h) b - k h (1 - h),   d smin = h da + (1 - h) db,
// so the gradient is a convex combination of the primitives' gradients and
// both neighbours slow the arm down near a seam. Error bound, M primitives:
//     min_j d_j - (M - 1) k / 4  <=  d_union  <=  min_j d_j,
// and d_union == min_j d_j wherever the nearest primitive is at least
// (M + 2) k / 4 nearer than all others (k when M = 2: the primitives folded
// before the nearest one lower the running value by up to k / 4 each, and a
// pair step is exact once its two values differ by k). The smooth value never exceeds the exact one, so a
// constraint delta - d_union <= 0 still implies delta - min_j d_j <= 0. With
// blend == 0 the union is the exact min with the nearest primitive's gradient.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace atacom {

enum class ShapeType : uint8_t { Sphere = 0, Capsule = 1, Box = 2, CylinderZ = 3 };

struct Shape {
  ShapeType type = ShapeType::Sphere;
  double a[3] = {0, 0, 0};     // sphere centre, capsule end, box centre, cylinder centre (mid height)
  double b[3] = {0, 0, 0};     // capsule other end
  double half[3] = {0, 0, 0};  // box half extents; cylinder: (-, -, half height)
  double radius = 0.0;         // sphere, capsule, cylinder
  std::string name;            // for messages and diagnostics

  static Shape sphere(const Eigen::Vector3d& c, double r, std::string name = "");
  static Shape capsule(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, std::string name = "");
  static Shape box(const Eigen::Vector3d& center, const Eigen::Vector3d& half, std::string name = "");
  static Shape cylinder_z(const Eigen::Vector3d& center, double r, double half_height, std::string name = "");
};

// Exact signed distance of p to the shape; grad (optional) = d distance / dp.
double shape_distance(const Shape& s, const Eigen::Vector3d& p, Eigen::Vector3d* grad = nullptr);

struct ShapeUnion {
  std::vector<Shape> shapes;
  double blend = 0.0;  // k of the smooth minimum, m; 0 = exact min
};

// Distance to the union (see the header comment); +inf for an empty union.
double union_distance(const ShapeUnion& u, const Eigen::Vector3d& p, Eigen::Vector3d* grad = nullptr);

// Exact minimum of min_j d_j (no blending), and the index of the nearest shape.
double union_distance_exact(const ShapeUnion& u, const Eigen::Vector3d& p, int* nearest = nullptr);

// min over t in [0, 1] of shape_distance(a + t (b - a)): the signed distance of
// a segment to a convex shape. The function of t is convex (signed distance to
// a convex set), so golden-section search finds it; the result is within
// 1e-9 m of the true minimum.
double segment_distance(const Shape& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b);

// Whether the segment stays at distance >= r from the convex shape, i.e.
// segment_distance(s, a, b) >= r, answered with early exits: a bound from the
// midpoint (1-Lipschitz distance), a sample below r, or a bracket whose
// Lipschitz lower bound clears r. Same 1e-9 m resolution.
bool segment_clear(const Shape& s, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r);

// Smooth minimum pair rule (exposed for the tests).
double smooth_min(double a, double b, double k, double* wa = nullptr);

}  // namespace atacom
