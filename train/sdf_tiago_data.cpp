#include "train/sdf_tiago_data.hpp"

#include <cmath>
#include <stdexcept>

#include "envs/arm/arm_scene.hpp"

namespace atacom {

ShapeUnion tiago_body_geometry(double lift) {
  // The body does not depend on the task; the table scene is as good as any.
  return build_arm_scene(default_arm_scene_config(ArmTask::Table), load_tiago_arm_model(lift)).body;
}

namespace {
void shape_bounds(const Shape& s, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  Eigen::Vector3d h;
  if (s.type == ShapeType::Box) h = {s.half[0], s.half[1], s.half[2]};
  else if (s.type == ShapeType::CylinderZ) h = {s.radius, s.radius, s.half[2]};
  else if (s.type == ShapeType::Sphere) h.setConstant(s.radius);
  else throw std::invalid_argument("learned SDF data: shape '" + s.name + "' is a capsule (not sampled here)");
  const Eigen::Vector3d c(s.a[0], s.a[1], s.a[2]);
  lo = lo.cwiseMin(c - h);
  hi = hi.cwiseMax(c + h);
}

void union_bounds(const ShapeUnion& u, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  lo.setConstant(1e300);
  hi.setConstant(-1e300);
  for (const Shape& s : u.shapes) shape_bounds(s, lo, hi);
}
}  // namespace

Eigen::Vector3d tiago_body_centre() {
  Eigen::Vector3d lo, hi;
  union_bounds(tiago_body_geometry(0.5 * kTiagoSdfLiftMax), lo, hi);
  return 0.5 * (lo + hi);
}

double shape_surface_area(const Shape& s) {
  switch (s.type) {
    case ShapeType::Box: return 8.0 * (s.half[0] * s.half[1] + s.half[1] * s.half[2] + s.half[0] * s.half[2]);
    case ShapeType::CylinderZ: return 2.0 * M_PI * s.radius * (2.0 * s.half[2]) + 2.0 * M_PI * s.radius * s.radius;
    case ShapeType::Sphere: return 4.0 * M_PI * s.radius * s.radius;
    default: throw std::invalid_argument("learned SDF data: shape '" + s.name + "' is a capsule (not sampled here)");
  }
}

void sample_shape_surface(const Shape& s, Rng& rng, Eigen::Vector3d& point, Eigen::Vector3d& normal) {
  const Eigen::Vector3d c(s.a[0], s.a[1], s.a[2]);
  normal.setZero();
  if (s.type == ShapeType::Box) {
    double u = rng.uniform() * 0.5 * shape_surface_area(s);  // one face of each opposite pair, then the side
    int ax = 0;
    for (; ax < 2; ++ax) {
      const double a = 4.0 * s.half[(ax + 1) % 3] * s.half[(ax + 2) % 3];
      if (u <= a) break;
      u -= a;
    }
    const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
    for (int k = 0; k < 3; ++k) point(k) = s.a[k] + s.half[k] * rng.uniform(-1.0, 1.0);
    point(ax) = s.a[ax] + sign * s.half[ax];
    normal(ax) = sign;
  } else if (s.type == ShapeType::CylinderZ) {
    const double r = s.radius, h = s.half[2];
    const double side = 2.0 * r * (2.0 * h), caps = 2.0 * r * r;  // shares of 2 pi r (2h) and 2 pi r^2 (over pi)
    if (rng.uniform() * (side + caps) < side) {
      const double phi = rng.uniform(0.0, 2.0 * M_PI);
      normal = {std::cos(phi), std::sin(phi), 0.0};
      point = c + r * normal;
      point.z() = c.z() + h * rng.uniform(-1.0, 1.0);
    } else {
      const double rr = r * std::sqrt(rng.uniform()), phi = rng.uniform(0.0, 2.0 * M_PI);
      const double sign = rng.uniform() < 0.5 ? -1.0 : 1.0;
      point = {c.x() + rr * std::cos(phi), c.y() + rr * std::sin(phi), c.z() + sign * h};
      normal.z() = sign;
    }
  } else if (s.type == ShapeType::Sphere) {
    do normal = Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    while (normal.squaredNorm() > 1.0 || normal.squaredNorm() < 1e-6);
    normal.normalize();
    point = c + s.radius * normal;
  } else {
    throw std::invalid_argument("learned SDF data: shape '" + s.name + "' is a capsule (not sampled here)");
  }
}

SdfSamples make_tiago_sdf_samples(const SdfDataConfig& cfg) {
  Rng rng(cfg.seed, 0x7a60);
  SdfSamples out;
  out.pose_dim = 1;
  out.poses.reserve(size_t(cfg.poses));
  for (int pi = 0; pi < cfg.poses; ++pi) {
    const double lift = rng.uniform(0.0, kTiagoSdfLiftMax);
    out.poses.push_back(float(lift));
    const ShapeUnion body = tiago_body_geometry(double(float(lift)));  // the lift the network sees
    ShapeUnion exact = body, label = body;
    exact.blend = 0.0;
    if (cfg.blend >= 0.0) label.blend = cfg.blend;
    auto push = [&](const Eigen::Vector3d& x, bool shifted) {
      Eigen::Vector3d g;
      const double d = union_distance(label, x, &g);
      for (int k = 0; k < 3; ++k) out.p.push_back(float(x(k))), out.grad.push_back(float(g(k)));
      out.y.push_back(float(d));
      out.pose_id.push_back(pi);
      out.shifted.push_back(shifted);
      ++out.n;
    };
    std::vector<double> area;
    double total = 0;
    for (const Shape& s : body.shapes) total += area.emplace_back(shape_surface_area(s));
    int accepted = 0;
    for (int tries = 0; accepted < cfg.surface_points && tries < 50 * cfg.surface_points; ++tries) {
      double u = rng.uniform() * total;
      size_t si = 0;
      while (si + 1 < area.size() && u > area[si]) u -= area[si++];
      Eigen::Vector3d s, nrm;
      sample_shape_surface(body.shapes[si], rng, s, nrm);
      if (union_distance_exact(exact, s) < -1e-9) continue;  // buried in another part: not on the body's surface
      ++accepted;
      for (double e : cfg.epsilons) push(s + e * nrm, true);
    }
    Eigen::Vector3d lo, hi;
    union_bounds(body, lo, hi);
    const int nvol = int(std::lround(cfg.volume_fraction * accepted * double(cfg.epsilons.size())));
    const Eigen::Vector3d vm = Eigen::Vector3d::Constant(cfg.volume_margin), vlo = lo - vm, vhi = hi + vm;
    for (int i = 0; i < nvol; ++i)
      push({rng.uniform(vlo.x(), vhi.x()), rng.uniform(vlo.y(), vhi.y()), rng.uniform(vlo.z(), vhi.z())}, false);
  }
  return out;
}

}  // namespace atacom
