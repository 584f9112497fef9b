#include "kernels/redsdf_human_lanes.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace atacom {

void learned_human_distance_lanes(const LearnedHuman& o, const double* pose, const double* rate, int cnt,
                                  const lanes::vd (*poi)[3], int npoi, lanes::vd* d, lanes::vd (*g)[3],
                                  lanes::vd* ddt) {
  constexpr int L = lanes::kLanes, P = kHumanDofs;
  if (npoi > kLearnedHumanMaxPoi || cnt < 1) throw std::logic_error("learned_human_distance_lanes: bad sizes");
  if (!pose || !rate) throw std::logic_error("learned_human_distance_lanes: no human poses (HumanCapsLanes::pose unset)");
  alignas(64) float p[kLearnedHumanMaxPoi * L * 3], q[kLearnedHumanMaxPoi * L * P];
  alignas(64) float dd[kLearnedHumanMaxPoi * L], gg[kLearnedHumanMaxPoi * L * 3], gq[kLearnedHumanMaxPoi * L * P];
  double cs[L], sn[L];
  for (int l = 0; l < L; ++l) {
    const double* x = pose + size_t(std::min(l, cnt - 1)) * kHumanPoseDim;
    cs[l] = std::cos(x[3]), sn[l] = std::sin(x[3]);
    for (int i = 0; i < npoi; ++i) {
      const double dx = poi[i][0][l] - x[0], dy = poi[i][1][l] - x[1], dz = poi[i][2][l] - x[2];
      float* pb = p + 3 * (i * L + l);
      pb[0] = float(cs[l] * dx + sn[l] * dy);
      pb[1] = float(-sn[l] * dx + cs[l] * dy);
      pb[2] = float(dz);
      float* qi = q + size_t(i * L + l) * P;
      for (int k = 0; k < P; ++k) qi[k] = float(x[kHumanRootDofs + k]);
    }
  }
  o.batch->evaluate_range(p, q, false, 0, int64_t(npoi) * L, dd, gg, gq);
  for (int l = 0; l < L; ++l) {
    const double* xd = rate + size_t(std::min(l, cnt - 1)) * kHumanPoseDim;
    const double c = cs[l], s = sn[l];
    // Rz^T rdot, and the yaw rate.
    const double rb0 = c * xd[0] + s * xd[1], rb1 = -s * xd[0] + c * xd[1], rb2 = xd[2], w = xd[3];
    for (int i = 0; i < npoi; ++i) {
      const int r = i * L + l;
      const float* pb = p + 3 * r;
      const float* gb = gg + 3 * r;
      d[i][l] = dd[r];
      g[i][0][l] = c * gb[0] - s * gb[1];
      g[i][1][l] = s * gb[0] + c * gb[1];
      g[i][2][l] = gb[2];
      double rate_d = double(gb[0]) * (w * pb[1] - rb0) + double(gb[1]) * (-w * pb[0] - rb1) - double(gb[2]) * rb2;
      const float* gqi = gq + size_t(r) * P;
      for (int k = 0; k < P; ++k) rate_d += double(gqi[k]) * xd[kHumanRootDofs + k];
      ddt[i][l] = rate_d;
    }
  }
}

}  // namespace atacom
