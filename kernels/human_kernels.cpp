#include "kernels/human_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "kernels/human_fk_lanes.hpp"
#include "kernels/human_rows_lanes.hpp"

namespace atacom {

using lanes::kLanes;
using lanes::vd;

void HumanBatch::resize(int n) {
  if (n < 0) throw std::invalid_argument("HumanBatch: N must be >= 0");
  N = n;
  const size_t sn = static_cast<size_t>(n);
  pose.assign(sn * kHumanPoseDim, 0.0);
  pose_rate.assign(sn * kHumanPoseDim, 0.0);
  cap.assign(sn * kHumanCapStride, 0.0);
  cap_vel.assign(sn * kHumanCapStride, 0.0);
}

void human_capsules_range(const HumanFkConst& k, HumanBatch& B, int begin, int end, bool with_velocity) {
  for (int e0 = begin; e0 < end; e0 += kLanes) {
    const int cnt = std::min(kLanes, end - e0);
    vd pose[kHumanPoseDim], rate[kHumanPoseDim];
    lanes::human_load_pose_lanes(B, e0, cnt, pose, rate, with_velocity);
    lanes::HumanCapsLanes o;
    lanes::human_fk_lanes(k, pose, rate, o, with_velocity);
    lanes::human_store_caps_lanes(o, B, e0, cnt, with_velocity);
  }
}

void human_rows_range(const HumanRowsConst& k, const HumanFkConst& hk, const HumanBatch& B, const double* poi,
                      const double* J_poi, double* c, double* Jq, double* dcdt, double* d_exact, int begin, int end) {
  const int P = k.num_poi, nq = k.nq;
  if (P < 0 || P > kHumanMaxPoi || nq < 0 || nq > kHumanMaxNq)
    throw std::invalid_argument("human_rows_range: num_poi must be in [0, 16] and nq in [0, 8]");
  for (int e0 = begin; e0 < end; e0 += kLanes) {
    const int cnt = std::min(kLanes, end - e0);
    lanes::HumanCapsLanes h;
    lanes::human_load_caps_lanes(&B.cap[static_cast<size_t>(e0) * kHumanCapStride], &B.cap_vel[static_cast<size_t>(e0) * kHumanCapStride],
                                 cnt, h);
    vd p[kHumanMaxPoi][3], Jp[kHumanMaxPoi][3][kHumanMaxNq];
    const int ps = P * 3, js = P * 3 * nq;
    for (int i = 0; i < P; ++i)
      for (int r = 0; r < 3; ++r) {
        p[i][r] = lanes::load_strided(poi + static_cast<size_t>(e0) * ps + i * 3 + r, ps, cnt);
        for (int j = 0; j < nq; ++j)
          Jp[i][r][j] = lanes::load_strided(J_poi + static_cast<size_t>(e0) * js + (i * 3 + r) * nq + j, js, cnt);
      }
    vd cl[kHumanMaxPoi], Jl[kHumanMaxPoi][kHumanMaxNq], dl[kHumanMaxPoi], xl[kHumanMaxPoi];
    lanes::human_rows_lanes<kHumanMaxNq>(k, hk, p, Jp, h, cl, Jl, dl, xl);
    for (int l = 0; l < cnt; ++l) {
      const size_t e = static_cast<size_t>(e0 + l);
      for (int i = 0; i < P; ++i) {
        c[e * P + i] = cl[i][l];
        dcdt[e * P + i] = dl[i][l];
        if (d_exact) d_exact[e * P + i] = xl[i][l];
        for (int j = 0; j < nq; ++j) Jq[(e * P + i) * nq + j] = Jl[i][j][l];
      }
    }
  }
}

double human_segment_distance(const HumanFkConst& k, const double* cap, const double* a, const double* b) {
  double best = INFINITY;
  for (int c = 0; c < kHumanCapsules; ++c)
    best = std::min(best, std::sqrt(human_impl::segment_segment_distance2(a, b, cap + c * 6, cap + c * 6 + 3)) -
                              k.cap_radius[c]);
  return best;
}

void human_contact_range(const HumanBatch& B, const HumanFkConst& k, const double* items, const double* radii,
                         int n_items, uint8_t* contact, double* min_distance, int begin, int end) {
  static_assert(kHumanCapsules == 2 * kLanes, "the broad phase holds the capsules in two lane vectors");
  // Per capsule: half length + radius (rigid), in lane order.
  vd cext[2];
  for (int c = 0; c < kHumanCapsules; ++c)
    cext[c / kLanes][c % kLanes] =
        (k.cap_inv_len2[c] > 0.0 ? 0.5 / std::sqrt(k.cap_inv_len2[c]) : 0.0) + k.cap_radius[c];
  for (int e = begin; e < end; ++e) {
    const size_t se = static_cast<size_t>(e);
    const double* cap = &B.cap[se * kHumanCapStride];
    const double* it = items + se * static_cast<size_t>(n_items) * 6;
    vd cm[2][3];  // capsule midpoints, 8 capsules per vector
    for (int c = 0; c < kHumanCapsules; ++c)
      for (int r = 0; r < 3; ++r) cm[c / kLanes][r][c % kLanes] = 0.5 * (cap[c * 6 + r] + cap[c * 6 + 3 + r]);
    bool hit = false;
    double best = INFINITY;  // smallest surface distance found so far
    for (int i = 0; i < n_items && !(hit && !min_distance); ++i) {
      const double* ia = it + i * 6;
      const double* ib = ia + 3;
      double im[3], ih2 = 0.0;
      for (int r = 0; r < 3; ++r) {
        im[r] = 0.5 * (ia[r] + ib[r]);
        ih2 += 0.25 * (ib[r] - ia[r]) * (ib[r] - ia[r]);
      }
      // Broad phase, all 16 capsules at once: two segments are at least
      // |midpoint distance| - both half lengths apart, so a pair is skipped
      // when that clears both radii (plus the best distance so far, if wanted).
      const double slack = std::sqrt(ih2) + radii[i] + (min_distance ? best : 0.0);
      for (int g = 0; g < 2; ++g) {
        const vd reach = cext[g] + slack;
        const vd dx = cm[g][0] - im[0], dy = cm[g][1] - im[1], dz = cm[g][2] - im[2];
        const lanes::vm cand = (reach > 0.0) & (dx * dx + dy * dy + dz * dz < reach * reach);
        if (!lanes::any(cand)) continue;
        for (int l = 0; l < kLanes; ++l) {
          if (!cand[l]) continue;
          const int c = g * kLanes + l;
          const double* ca = cap + c * 6;
          const double d =
              std::sqrt(human_impl::segment_segment_distance2(ia, ib, ca, ca + 3)) - radii[i] - k.cap_radius[c];
          best = std::min(best, d);
          if (d < 0.0) hit = true;
        }
        if (hit && !min_distance) break;
      }
    }
    contact[e] = hit ? 1 : 0;
    if (min_distance) min_distance[e] = best;
  }
}

}  // namespace atacom
