#include "train/sdf_data.hpp"

#include <cmath>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

SdfDataConfig default_sdf_data_config() {
  SdfDataConfig c;
  c.epsilons = {0.0025, 0.005, 0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.16, 0.2,
                0.25,   0.3,   0.4,  0.5,  -0.0025, -0.005, -0.01, -0.05, -0.1, -0.15};
  return c;
}

void to_json(nlohmann::json& j, const SdfDataConfig& c) {
  j = {{"surface_points", c.surface_points}, {"epsilons", c.epsilons}, {"volume_fraction", c.volume_fraction},
       {"volume_margin", c.volume_margin},   {"poses", c.poses}, {"blend", c.blend},  {"seed", c.seed}};
}

void from_json(const nlohmann::json& j, SdfDataConfig& c) {
  ConfigReader r(j, "data");
  r.get("surface_points", c.surface_points, range::closed(1, 1 << 22));
  r.get("epsilons", c.epsilons);
  r.get("volume_fraction", c.volume_fraction, range::closed(0.0, 10.0));
  r.get("volume_margin", c.volume_margin, range::closed(0.0, 10.0));
  r.get("poses", c.poses, range::closed(1, 1 << 20));
  r.get("blend", c.blend, range::closed(-1.0, 0.5));
  r.get("seed", c.seed);
  r.finish();
  if (c.blend < 0.0 && c.blend != -1.0)
    throw std::invalid_argument("config key 'data.blend' must be -1 (the object's own) or in [0, 0.5]");
  if (c.epsilons.empty() || c.epsilons.size() > 256)
    throw std::invalid_argument("config key 'data.epsilons' must hold 1 to 256 offsets");
  for (double e : c.epsilons)
    if (!std::isfinite(e) || std::abs(e) > 2.0)
      throw std::invalid_argument("config key 'data.epsilons' holds " + std::to_string(e) + ", must be in [-2, 2]");
}

void union_box_bounds(const ShapeUnion& object, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  lo.setConstant(1e300);
  hi.setConstant(-1e300);
  for (const Shape& s : object.shapes) {
    if (s.type != ShapeType::Box)
      throw std::invalid_argument("learned SDF data: shape '" + s.name + "' is not a box (only boxes are sampled)");
    for (int k = 0; k < 3; ++k) {
      lo(k) = std::min(lo(k), s.a[k] - s.half[k]);
      hi(k) = std::max(hi(k), s.a[k] + s.half[k]);
    }
  }
}

SdfSamples make_static_sdf_samples(const ShapeUnion& object, const SdfDataConfig& cfg) {
  Eigen::Vector3d lo, hi;
  union_box_bounds(object, lo, hi);
  ShapeUnion exact = object, label = object;
  exact.blend = 0.0;
  if (cfg.blend >= 0.0) label.blend = cfg.blend;
  // Faces weighted by area.
  struct Face { int shape, axis; double sign, area; };
  std::vector<Face> faces;
  double total = 0;
  for (int i = 0; i < int(object.shapes.size()); ++i) {
    const Shape& s = object.shapes[size_t(i)];
    for (int ax = 0; ax < 3; ++ax)
      for (double sg : {-1.0, 1.0}) {
        const double area = 4.0 * s.half[(ax + 1) % 3] * s.half[(ax + 2) % 3];
        faces.push_back({i, ax, sg, area});
        total += area;
      }
  }
  Rng rng(cfg.seed, 0xda7a);
  SdfSamples out;
  auto push = [&](const Eigen::Vector3d& q, bool shifted) {
    Eigen::Vector3d g;
    const double d = union_distance(label, q, &g);
    for (int k = 0; k < 3; ++k) out.p.push_back(float(q(k))), out.grad.push_back(float(g(k)));
    out.y.push_back(float(d));
    out.shifted.push_back(shifted);
    ++out.n;
  };
  int accepted = 0;
  for (int tries = 0; accepted < cfg.surface_points && tries < 50 * cfg.surface_points; ++tries) {
    double u = rng.uniform() * total;
    size_t fi = 0;
    while (fi + 1 < faces.size() && u > faces[fi].area) u -= faces[fi++].area;
    const Face& f = faces[fi];
    const Shape& s = object.shapes[size_t(f.shape)];
    Eigen::Vector3d q, nrm = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) q(k) = s.a[k] + s.half[k] * rng.uniform(-1.0, 1.0);
    q(f.axis) = s.a[f.axis] + f.sign * s.half[f.axis];
    nrm(f.axis) = f.sign;
    // A face point buried inside another part is not on the union's surface.
    if (union_distance_exact(exact, q) < -1e-9) continue;
    ++accepted;
    for (double e : cfg.epsilons) push(q + e * nrm, true);
  }
  const int nvol = int(std::lround(cfg.volume_fraction * out.n));
  const Eigen::Vector3d vlo = lo.array() - cfg.volume_margin, vhi = hi.array() + cfg.volume_margin;
  for (int i = 0; i < nvol; ++i)
    push({rng.uniform(vlo.x(), vhi.x()), rng.uniform(vlo.y(), vhi.y()), rng.uniform(vlo.z(), vhi.z())}, false);
  return out;
}

}  // namespace atacom
