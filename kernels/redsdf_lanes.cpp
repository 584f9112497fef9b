#include "kernels/redsdf_lanes.hpp"

#include <stdexcept>

namespace atacom {

void learned_distance_lanes(const LearnedObstacle& o, const lanes::vd (*poi)[3], int npoi, lanes::vd* d,
                            lanes::vd (*g)[3]) {
  constexpr int L = lanes::kLanes;
  if (npoi > kLearnedMaxPoi) throw std::logic_error("learned_distance_lanes: too many points");
  alignas(64) float p[kLearnedMaxPoi * L * 3], dd[kLearnedMaxPoi * L], gg[kLearnedMaxPoi * L * 3];
  const Eigen::Matrix3d& R = o.R;
  for (int i = 0; i < npoi; ++i)
    for (int l = 0; l < L; ++l) {
      // object frame: R^T (p - t)
      const double x = poi[i][0][l] - o.t.x(), y = poi[i][1][l] - o.t.y(), z = poi[i][2][l] - o.t.z();
      float* q = p + 3 * (i * L + l);
      for (int k = 0; k < 3; ++k) q[k] = float(R(0, k) * x + R(1, k) * y + R(2, k) * z);
    }
  o.batch->evaluate_range(p, o.pose.empty() ? nullptr : o.pose.data(), true, 0, int64_t(npoi) * L, dd, g ? gg : nullptr);
  for (int i = 0; i < npoi; ++i)
    for (int l = 0; l < L; ++l) {
      d[i][l] = dd[i * L + l];
      if (!g) continue;
      const float* q = gg + 3 * (i * L + l);
      for (int k = 0; k < 3; ++k) g[i][k][l] = R(k, 0) * q[0] + R(k, 1) * q[1] + R(k, 2) * q[2];
    }
}

double learned_distance_reference(const LearnedObstacle& o, const Eigen::Vector3d& p, Eigen::Vector3d* g) {
  const std::vector<double> pose(o.pose.begin(), o.pose.end());
  Eigen::Vector3d gl;
  const double d = redsdf_reference(*o.model, o.R.transpose() * (p - o.t), pose.empty() ? nullptr : pose.data(), g ? &gl : nullptr);
  if (g) *g = o.R * gl;
  return d;
}

}  // namespace atacom
