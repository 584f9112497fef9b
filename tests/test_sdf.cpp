// Signed distance primitives and unions: closed-form values, gradients
// against finite differences, the smooth-union error bound, segment distances
// against brute force, and SIMD lanes against the scalar path.
#include <catch2/catch.hpp>

#include <cmath>

#include "atacom/rng.hpp"
#include "kernels/sdf.hpp"
#include "kernels/sdf_impl.hpp"

using namespace atacom;
using Eigen::Vector3d;

namespace {
std::vector<Shape> sample_shapes() {
  return {Shape::sphere({0.1, -0.2, 0.3}, 0.15, "sphere"),
          Shape::capsule({-0.2, 0.1, 0.0}, {0.3, 0.2, 0.4}, 0.07, "capsule"),
          Shape::box({0.2, 0.1, -0.1}, {0.3, 0.1, 0.05}, "box"),
          Shape::cylinder_z({-0.1, 0.0, 0.2}, 0.27, 0.15, "cylinder")};
}
Vector3d random_point(Rng& rng, double r = 0.8) { return {rng.uniform(-r, r), rng.uniform(-r, r), rng.uniform(-r, r)}; }
Vector3d fd_grad(const std::function<double(const Vector3d&)>& f, const Vector3d& p, double h = 1e-6) {
  Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Vector3d a = p, b = p;
    a(k) += h;
    b(k) -= h;
    g(k) = (f(a) - f(b)) / (2 * h);
  }
  return g;
}
}  // namespace

TEST_CASE("primitive distances match closed forms", "[sdf]") {
  const Shape box = Shape::box({1, 2, 3}, {0.5, 0.2, 0.1});
  Vector3d g;
  CHECK(shape_distance(box, {1, 2, 3.3}, &g) == Approx(0.2));                   // above the top face
  CHECK((g - Vector3d(0, 0, 1)).norm() < 1e-15);
  CHECK(shape_distance(box, {1.8, 2.6, 3}) == Approx(std::hypot(0.3, 0.4)));   // beside an edge
  CHECK(shape_distance(box, {1.5 + 0.1, 2.2 + 0.2, 3.1 + 0.2}) == Approx(0.3)); // beyond a corner
  CHECK(shape_distance(box, {1.1, 2.0, 3.0}, &g) == Approx(-0.1));              // inside: nearest face is z
  CHECK((g - Vector3d(0, 0, 1)).norm() < 1e-15);
  const Shape sph = Shape::sphere({0, 0, 0}, 0.5);
  CHECK(shape_distance(sph, {0, 0.8, 0}) == Approx(0.3));
  CHECK(shape_distance(sph, {0, 0, 0}, &g) == Approx(-0.5));
  CHECK((g - Vector3d(0, 0, 1)).norm() == 0.0);  // documented choice at the centre
  const Shape cap = Shape::capsule({0, 0, 0}, {1, 0, 0}, 0.1);
  CHECK(shape_distance(cap, {0.5, 0.3, 0}) == Approx(0.2));
  CHECK(shape_distance(cap, {1.4, 0, 0}) == Approx(0.3));
  const Shape cyl = Shape::cylinder_z({0, 0, 0.5}, 0.27, 0.5);
  CHECK(shape_distance(cyl, {0.5, 0, 0.5}) == Approx(0.23));
  CHECK(shape_distance(cyl, {0, 0.1, 1.2}) == Approx(0.2));
  CHECK(shape_distance(cyl, {0.27 + 0.3, 0, 1.4}) == Approx(0.5));
  CHECK(shape_distance(cyl, {0.2, 0, 0.5}) == Approx(-0.07));
}

TEST_CASE("primitive gradients match finite differences", "[sdf]") {
  Rng rng(1, 0);
  for (const Shape& s : sample_shapes()) {
    for (int i = 0; i < 2000; ++i) {
      const Vector3d p = random_point(rng);
      Vector3d g;
      shape_distance(s, p, &g);
      const Vector3d fd = fd_grad([&](const Vector3d& x) { return shape_distance(s, x); }, p);
      INFO(s.name << " at " << p.transpose());
      CHECK((g - fd).norm() < 1e-6);
    }
  }
}

TEST_CASE("smooth union: bounded below the exact min, C1 gradient", "[sdf]") {
  ShapeUnion u;
  u.shapes = sample_shapes();
  u.blend = 0.03;
  ShapeUnion exact = u;
  exact.blend = 0.0;
  const double bound = (u.shapes.size() - 1) * u.blend / 4.0;
  Rng rng(2, 0);
  for (int i = 0; i < 5000; ++i) {
    const Vector3d p = random_point(rng);
    Vector3d g, ge;
    const double d = union_distance(u, p, &g);
    int nearest = -1;
    const double dmin = union_distance_exact(u, p, &nearest);
    CHECK(d <= dmin + 1e-15);
    CHECK(d >= dmin - bound - 1e-15);
    CHECK(union_distance(exact, p, &ge) == dmin);
    Vector3d gn;
    shape_distance(u.shapes[nearest], p, &gn);
    CHECK((ge - gn).norm() == 0.0);
    const Vector3d fd = fd_grad([&](const Vector3d& x) { return union_distance(u, x); }, p);
    INFO("at " << p.transpose());
    CHECK((g - fd).norm() < 1e-5);
    CHECK(g.norm() <= 1.0 + 1e-12);
  }
  // Exactly the min when one primitive is clearly nearest.
  CHECK(union_distance(u, {0.1, -0.2, 0.5}) == Approx(union_distance_exact(u, {0.1, -0.2, 0.5})).margin(0));
}

TEST_CASE("segment distance to convex shapes equals the brute-force minimum", "[sdf]") {
  Rng rng(5, 0);
  for (const Shape& s : sample_shapes()) {
    for (int i = 0; i < 200; ++i) {
      const Vector3d a = random_point(rng), b = random_point(rng);
      const double d = segment_distance(s, a, b);
      double brute = 1e9;
      for (int k = 0; k <= 4000; ++k) brute = std::min(brute, shape_distance(s, a + (k / 4000.0) * (b - a)));
      INFO(s.name);
      CHECK(d <= brute + 1e-9);
      CHECK(d >= brute - (b - a).norm() / 4000.0);
    }
  }
}

TEST_CASE("SIMD lanes compute the scalar distances", "[sdf]") {
  using lanes::kLanes;
  using lanes::vd;
  const auto shapes = sample_shapes();
  Rng rng(9, 0);
  vd p[3];
  for (int l = 0; l < kLanes; ++l)
    for (int k = 0; k < 3; ++k) p[k][l] = rng.uniform(-0.8, 0.8);
  for (double blend : {0.0, 0.03}) {
    vd g[3];
    const vd d = sdf_impl::union_of<vd>(shapes.data(), static_cast<int>(shapes.size()), blend, p, g);
    ShapeUnion u{shapes, blend};
    for (int l = 0; l < kLanes; ++l) {
      Vector3d gs;
      const double ds = union_distance(u, {p[0][l], p[1][l], p[2][l]}, &gs);
      // Not bitwise: the compiler may contract a*b+c into an FMA differently
      // in the scalar and the vector code.
      CHECK(std::abs(ds - d[l]) < 1e-15);
      for (int k = 0; k < 3; ++k) CHECK(std::abs(gs(k) - g[k][l]) < 1e-14);
    }
  }
}

TEST_CASE("segment_clear agrees with segment_distance", "[sdf]") {
  Rng rng(6, 0);
  int clear = 0, blocked = 0;
  for (const Shape& s : sample_shapes()) {
    for (int i = 0; i < 3000; ++i) {
      const Vector3d a = random_point(rng), b = random_point(rng);
      const double r = rng.uniform(0.0, 0.3);
      const double d = segment_distance(s, a, b);
      if (std::abs(d - r) < 1e-8) continue;  // within the search resolution
      const bool c = segment_clear(s, a, b, r);
      CHECK(c == (d >= r));
      (c ? clear : blocked)++;
    }
  }
  CHECK(clear > 1000);
  CHECK(blocked > 1000);
}
