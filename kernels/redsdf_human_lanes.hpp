// The learned (ReDSDF) human field evaluated for lane blocks of the HRI env:
// the PoIs of kLanes envs go through the pose-conditioned network as one
// batch on the calling thread (train/sdf_human_data.hpp: body frame, the 34
// joint angles as the pose input).
//
// Per point p (robot base frame) of an env whose human has root (x, y, z,
// yaw) and joint angles q:
//   p_b = Rz(yaw)^T (p - r),  d = net(p_b, q),  grad_p d = Rz grad_pb d,
//   dd/dt at fixed p = grad_pb d . (yawdot (p_b.y, -p_b.x, 0) - Rz^T rdot)
//                      + grad_q d . qdot
// with grad_q d from the same backward pass (kernels/redsdf_batch.hpp). The
// rows are those of kernels/human_kernels.hpp with d learned:
//   c = delta - d,  J_q = -grad_p d . J_poi,  dcdt = -dd/dt,
// where the env has already added the model's margin to delta.
#pragma once
#include <memory>

#include "kernels/human_kernels.hpp"
#include "kernels/lanes.hpp"
#include "kernels/redsdf_batch.hpp"

namespace atacom {

struct LearnedHuman {
  std::shared_ptr<const RedsdfModel> model;
  std::shared_ptr<RedsdfBatch> batch;
  double margin = 0.0;  // the env adds it to every learned human row's threshold, m
};

constexpr int kLearnedHumanMaxPoi = 16;

// Humans of cnt consecutive envs: pose and rate (cnt x 38, HumanBatch
// layout); lanes past cnt repeat the last env. poi: npoi x 3 lane vectors.
// Writes d, g (grad_p d, base frame) and ddt (dd/dt at fixed p) per point.
void learned_human_distance_lanes(const LearnedHuman& o, const double* pose, const double* rate, int cnt,
                                  const lanes::vd (*poi)[3], int npoi, lanes::vd* d, lanes::vd (*g)[3],
                                  lanes::vd* ddt);

namespace lanes {

// The human rows with the learned field (thresholds k.delta[i], margin included).
template <int NQ>
static inline void learned_human_rows_lanes(const LearnedHuman& o, const HumanRowsConst& k, const double* pose,
                                            const double* rate, int cnt, const vd (*poi)[3], const vd (*Jp)[3][NQ],
                                            vd* c, vd (*J)[NQ], vd* dcdt) {
  vd d[kLearnedHumanMaxPoi], g[kLearnedHumanMaxPoi][3], ddt[kLearnedHumanMaxPoi];
  learned_human_distance_lanes(o, pose, rate, cnt, poi, k.num_poi, d, g, ddt);
  for (int i = 0; i < k.num_poi; ++i) {
    c[i] = k.delta[i] - d[i];
    dcdt[i] = -ddt[i];
    for (int j = 0; j < k.nq; ++j) J[i][j] = -(g[i][0] * Jp[i][0][j] + g[i][1] * Jp[i][1][j] + g[i][2] * Jp[i][2][j]);
  }
}

}  // namespace lanes
}  // namespace atacom
