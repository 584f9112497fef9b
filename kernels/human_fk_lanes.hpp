// Lane-block forward kinematics of the capsule human (kLanes envs at once):
// capsule end points and, forward-mode, their velocities.
//
// Per joint j with parent P: p_j = p_P + R_P o_j, R_j = R_P E_1 E_2 .. (the
// joint's angle rotations about signed principal axes). Velocities ride
// along: pdot_j = pdot_P + Rdot_P o_j, and one rotation E about axis e_k by
// theta turns (R, Rdot) into (R E, Rdot E + thetadot R E [e_k]x); both
// products only mix two columns. Root: R = Rz(yaw), p = (x, y, z).
#pragma once
#include "kernels/human_kernels.hpp"
#include "kernels/lanes.hpp"

namespace atacom::lanes {

struct HumanCapsLanes {
  vd a[kHumanCapsules][3], b[kHumanCapsules][3];    // end points, robot base frame
  vd va[kHumanCapsules][3], vb[kHumanCapsules][3];  // their velocities (when requested)
  // For a learned human field (kernels/redsdf_human_lanes.hpp): the poses and
  // rates (count x 38) of the lanes' envs; lanes past count repeat the last.
  const double* pose = nullptr;
  const double* pose_rate = nullptr;
  int count = 0;
};

struct HumanFrameLanes {
  vd R[9], Rd[9];  // rotation (row-major) and its time derivative
  vd p[3], pd[3];  // joint position and velocity
};

// (R, Rd) <- (R E, Rd E + w R E [e_k]x) for E = rotation about e_k by theta (rate w).
static inline void human_rotate(vd* R, vd* Rd, int k, vd theta, vd w, bool with_velocity) {
  const int i = (k + 1) % 3, j = (k + 2) % 3;
  vd s, c;
  vsincos(theta, s, c);
  for (int r = 0; r < 3; ++r) {
    const vd ri = R[r * 3 + i], rj = R[r * 3 + j];
    R[r * 3 + i] = c * ri + s * rj;
    R[r * 3 + j] = c * rj - s * ri;
  }
  if (!with_velocity) return;
  for (int r = 0; r < 3; ++r) {
    const vd di = Rd[r * 3 + i], dj = Rd[r * 3 + j];
    // (R E [e_k]x) e_i = (R E) e_j and (R E [e_k]x) e_j = -(R E) e_i.
    Rd[r * 3 + i] = c * di + s * dj + w * R[r * 3 + j];
    Rd[r * 3 + j] = c * dj - s * di - w * R[r * 3 + i];
  }
}

// pose, rate: kHumanPoseDim lane vectors each (rate ignored without velocity).
static inline void human_fk_lanes(const HumanFkConst& k, const vd* pose, const vd* rate, HumanCapsLanes& o,
                                  bool with_velocity = true) {
  HumanFrameLanes f[kHumanJoints];
  const vd zero = vd{};
  for (int j = 0; j < kHumanJoints; ++j) {
    if (!k.needed[j]) continue;
    HumanFrameLanes& F = f[j];
    const int par = k.parent[j];
    if (par < 0) {  // root: body frame at (x, y, z) turned by yaw, then the pelvis offset
      for (int e = 0; e < 9; ++e) F.R[e] = F.Rd[e] = zero;
      F.R[0] = F.R[4] = F.R[8] = splat(1.0);
      human_rotate(F.R, F.Rd, 2, pose[3], with_velocity ? rate[3] : zero, with_velocity);
      for (int r = 0; r < 3; ++r) {
        F.p[r] = pose[r] + (F.R[r * 3] * k.offset[j][0] + F.R[r * 3 + 1] * k.offset[j][1] + F.R[r * 3 + 2] * k.offset[j][2]);
        F.pd[r] = with_velocity ? rate[r] + (F.Rd[r * 3] * k.offset[j][0] + F.Rd[r * 3 + 1] * k.offset[j][1] +
                                             F.Rd[r * 3 + 2] * k.offset[j][2])
                                : zero;
      }
    } else {
      const HumanFrameLanes& P = f[par];
      for (int r = 0; r < 3; ++r) {
        F.p[r] = P.p[r] + (P.R[r * 3] * k.offset[j][0] + P.R[r * 3 + 1] * k.offset[j][1] + P.R[r * 3 + 2] * k.offset[j][2]);
        F.pd[r] = with_velocity ? P.pd[r] + (P.Rd[r * 3] * k.offset[j][0] + P.Rd[r * 3 + 1] * k.offset[j][1] +
                                             P.Rd[r * 3 + 2] * k.offset[j][2])
                                : zero;
      }
      for (int e = 0; e < 9; ++e) {
        F.R[e] = P.R[e];
        F.Rd[e] = with_velocity ? P.Rd[e] : zero;
      }
    }
    for (int d = 0; d < k.dof_count[j]; ++d) {
      const int q = k.dof_begin[j] + d;
      const double sg = k.sign[q];
      human_rotate(F.R, F.Rd, k.axis[q], sg * pose[q], with_velocity ? sg * rate[q] : zero, with_velocity);
    }
  }
  for (int c = 0; c < kHumanCapsules; ++c) {
    const HumanFrameLanes& F = f[k.cap_joint[c]];
    const double* a = k.cap_a[c];
    const double* b = k.cap_b[c];
    for (int r = 0; r < 3; ++r) {
      o.a[c][r] = F.p[r] + (F.R[r * 3] * a[0] + F.R[r * 3 + 1] * a[1] + F.R[r * 3 + 2] * a[2]);
      o.b[c][r] = F.p[r] + (F.R[r * 3] * b[0] + F.R[r * 3 + 1] * b[1] + F.R[r * 3 + 2] * b[2]);
      if (with_velocity) {
        o.va[c][r] = F.pd[r] + (F.Rd[r * 3] * a[0] + F.Rd[r * 3 + 1] * a[1] + F.Rd[r * 3 + 2] * a[2]);
        o.vb[c][r] = F.pd[r] + (F.Rd[r * 3] * b[0] + F.Rd[r * 3 + 1] * b[1] + F.Rd[r * 3 + 2] * b[2]);
      }
    }
  }
}

// Pose and rate lanes of envs [e0, e0 + cnt) (lanes past cnt repeat the last env).
static inline void human_load_pose_lanes(const HumanBatch& B, int e0, int cnt, vd* pose, vd* rate, bool with_rate = true) {
  const size_t base = static_cast<size_t>(e0) * kHumanPoseDim;
  for (int i = 0; i < kHumanPoseDim; ++i) {
    pose[i] = load_strided(&B.pose[base + i], kHumanPoseDim, cnt);
    rate[i] = with_rate ? load_strided(&B.pose_rate[base + i], kHumanPoseDim, cnt) : vd{};
  }
}

// Capsules and velocities of cnt consecutive envs from per-env arrays laid
// out like HumanBatch::cap / cap_vel (16 x 2 x 3 per env); lanes past cnt
// repeat the last env. vel == nullptr: velocities 0.
static inline void human_load_caps_lanes(const double* cap, const double* vel, int cnt, HumanCapsLanes& o) {
  constexpr int stride = kHumanCapsules * 6;
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      o.a[c][r] = load_strided(cap + c * 6 + r, stride, cnt);
      o.b[c][r] = load_strided(cap + c * 6 + 3 + r, stride, cnt);
      o.va[c][r] = vel ? load_strided(vel + c * 6 + r, stride, cnt) : vd{};
      o.vb[c][r] = vel ? load_strided(vel + c * 6 + 3 + r, stride, cnt) : vd{};
    }
}

// Capsules (and velocities) of lanes [0, cnt) into envs [e0, e0 + cnt) of the batch.
static inline void human_store_caps_lanes(const HumanCapsLanes& o, HumanBatch& B, int e0, int cnt,
                                          bool with_velocity = true) {
  constexpr int stride = kHumanCapsules * 6;
  for (int l = 0; l < cnt; ++l) {
    double* cap = &B.cap[static_cast<size_t>(e0 + l) * stride];
    double* vel = &B.cap_vel[static_cast<size_t>(e0 + l) * stride];
    for (int c = 0; c < kHumanCapsules; ++c)
      for (int r = 0; r < 3; ++r) {
        cap[c * 6 + r] = o.a[c][r][l];
        cap[c * 6 + 3 + r] = o.b[c][r][l];
        if (with_velocity) {
          vel[c * 6 + r] = o.va[c][r][l];
          vel[c * 6 + 3 + r] = o.vb[c][r][l];
        }
      }
  }
}

}  // namespace atacom::lanes
