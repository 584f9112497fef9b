#include "envs/arm/human_rows.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "kernels/sdf.hpp"

namespace atacom {

HumanRowsConst make_human_rows(const std::vector<double>& delta, int nq, double blend) {
  if (delta.size() > static_cast<size_t>(kHumanMaxPoi))
    throw std::invalid_argument("human rows: at most " + std::to_string(kHumanMaxPoi) + " points, got " +
                                std::to_string(delta.size()));
  if (nq < 1 || nq > kHumanMaxNq)
    throw std::invalid_argument("human rows: nq must be in [1, " + std::to_string(kHumanMaxNq) + "]");
  if (!(blend >= 0.0 && blend < 0.5)) throw std::invalid_argument("human rows: blend must be in [0, 0.5) m");
  HumanRowsConst k;
  k.num_poi = static_cast<int>(delta.size());
  k.nq = nq;
  k.blend = blend;
  for (size_t i = 0; i < delta.size(); ++i) {
    if (!std::isfinite(delta[i])) throw std::invalid_argument("human rows: delta must be finite");
    k.delta[i] = delta[i];
  }
  return k;
}

namespace {
ShapeUnion human_union(const HumanModel& m, const HumanFkResult& h, double blend, double dt) {
  ShapeUnion u;
  u.blend = blend;
  for (int c = 0; c < kHumanCapsules; ++c) {
    const size_t sc = static_cast<size_t>(c);
    u.shapes.push_back(Shape::capsule(h.a[sc] + dt * h.va[sc], h.b[sc] + dt * h.vb[sc], m.capsules[sc].radius,
                                      m.capsules[sc].name));
  }
  return u;
}
}  // namespace

HumanRowsReference human_rows_reference(const HumanModel& m, const HumanRowsConst& k, const HumanFkResult& human,
                                        const std::vector<Eigen::Vector3d>& poi,
                                        const std::vector<Eigen::MatrixXd>& J_poi, double h) {
  const int P = static_cast<int>(poi.size());
  if (P != k.num_poi || J_poi.size() != poi.size())
    throw std::invalid_argument("human_rows_reference: poi and J_poi must hold num_poi entries");
  HumanRowsReference r;
  r.c.resize(P);
  r.Jq.resize(P, k.nq);
  r.dcdt.resize(P);
  r.d_exact.resize(P);
  const ShapeUnion now = human_union(m, human, k.blend, 0.0);
  const ShapeUnion ahead = human_union(m, human, k.blend, h), behind = human_union(m, human, k.blend, -h);
  for (int i = 0; i < P; ++i) {
    Eigen::Vector3d g;
    const double d = union_distance(now, poi[static_cast<size_t>(i)], &g);
    r.c(i) = k.delta[i] - d;
    r.Jq.row(i) = -(g.transpose() * J_poi[static_cast<size_t>(i)]);
    const double dp = union_distance(ahead, poi[static_cast<size_t>(i)]);
    const double dm = union_distance(behind, poi[static_cast<size_t>(i)]);
    r.dcdt(i) = -(dp - dm) / (2.0 * h);
    r.d_exact(i) = union_distance_exact(now, poi[static_cast<size_t>(i)]);
  }
  return r;
}

double human_min_distance_reference(const HumanModel& m, const HumanFkResult& human,
                                    const std::vector<RobotPart>& parts) {
  double best = INFINITY;
  for (const RobotPart& part : parts)
    for (int c = 0; c < kHumanCapsules; ++c) {
      const size_t sc = static_cast<size_t>(c);
      const Shape cap = Shape::capsule(human.a[sc], human.b[sc], m.capsules[sc].radius);
      best = std::min(best, segment_distance(cap, part.a, part.b) - part.radius);
    }
  return best;
}

}  // namespace atacom
