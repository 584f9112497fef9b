#include "train/sdf_human_data.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "atacom/rng.hpp"
#include "kernels/human_rows_lanes.hpp"

namespace atacom {

void human_body_capsules(const HumanModel& model, const float* q, double* cap) {
  double pose[kHumanPoseDim] = {};
  for (int k = 0; k < kHumanDofs; ++k) pose[kHumanRootDofs + k] = q[k];
  const HumanFkResult fk = human_fk_reference(model, pose);
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) {
      cap[c * 6 + r] = fk.a[size_t(c)](r);
      cap[c * 6 + 3 + r] = fk.b[size_t(c)](r);
    }
}

double human_body_distance(const HumanModel& model, const double* cap, double blend, const double* p, double* g,
                           double* d_exact) {
  double A[kHumanCapsules][3], B[kHumanCapsules][3], V[kHumanCapsules][3] = {};
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int r = 0; r < 3; ++r) A[c][r] = cap[c * 6 + r], B[c][r] = cap[c * 6 + 3 + r];
  double gg[3], ddt = 0, de = 0;
  const double d = human_impl::human_point_distance<double>(A, B, V, V, model.fk.cap_inv_len2, model.fk.cap_radius,
                                                            blend, p, gg, ddt, de);
  if (g) g[0] = gg[0], g[1] = gg[1], g[2] = gg[2];
  if (d_exact) *d_exact = de;
  return d;
}

SdfSamples make_human_sdf_samples(const HumanModel& model, const HumanMotionLibrary& motion, const SdfDataConfig& cfg) {
  int lo = 0, hi = 0;
  motion.split_range(HumanSplit::Train, lo, hi);
  if (hi <= lo) throw std::runtime_error("human SDF data: the motion library's training split is empty");
  const double blend = cfg.blend >= 0.0 ? cfg.blend : kHumanSdfDefaultBlend;
  Rng rng(cfg.seed, 0x4a11);
  SdfSamples out;
  out.pose_dim = kHumanDofs;
  out.poses.reserve(size_t(cfg.poses) * kHumanDofs);
  double cap[kHumanCapsules * 6];
  for (int pi = 0; pi < cfg.poses; ++pi) {
    const int frame = lo + int(rng.below(uint64_t(hi - lo)));
    const float* q = &motion.frames[size_t(frame) * kHumanPoseDim + kHumanRootDofs];
    out.poses.insert(out.poses.end(), q, q + kHumanDofs);
    human_body_capsules(model, q, cap);
    auto push = [&](const Eigen::Vector3d& x, bool shifted) {
      double g[3];
      const double d = human_body_distance(model, cap, blend, x.data(), g);
      for (int k = 0; k < 3; ++k) out.p.push_back(float(x(k))), out.grad.push_back(float(g[k]));
      out.y.push_back(float(d));
      out.pose_id.push_back(pi);
      out.shifted.push_back(shifted);
      ++out.n;
    };
    // Capsule areas: cylinder 2 pi r L, the two hemispheres 4 pi r^2.
    double area[kHumanCapsules], total = 0;
    Eigen::Vector3d lo3 = Eigen::Vector3d::Constant(1e300), hi3 = -lo3;
    for (int c = 0; c < kHumanCapsules; ++c) {
      const Eigen::Vector3d a(cap + c * 6), b(cap + c * 6 + 3);
      const double r = model.fk.cap_radius[c];
      area[c] = 2 * M_PI * r * (b - a).norm() + 4 * M_PI * r * r;
      total += area[c];
      const Eigen::Vector3d rr = Eigen::Vector3d::Constant(r);
      lo3 = lo3.cwiseMin(a.cwiseMin(b) - rr);
      hi3 = hi3.cwiseMax(a.cwiseMax(b) + rr);
    }
    int accepted = 0;
    for (int tries = 0; accepted < cfg.surface_points && tries < 50 * cfg.surface_points; ++tries) {
      double u = rng.uniform() * total;
      int c = 0;
      while (c + 1 < kHumanCapsules && u > area[c]) u -= area[c++];
      const Eigen::Vector3d a(cap + c * 6), b(cap + c * 6 + 3);
      const double r = model.fk.cap_radius[c], len = (b - a).norm();
      const Eigen::Vector3d axis = len > 0 ? Eigen::Vector3d((b - a) / len) : Eigen::Vector3d::UnitZ();
      Eigen::Vector3d s, nrm;
      if (rng.uniform() * (2 * len + 4 * r) < 2 * len) {  // the cylinder (area share 2 pi r L of 2 pi r (L + 2 r))
        const Eigen::Vector3d e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
        const double phi = rng.uniform(0.0, 2 * M_PI);
        nrm = std::cos(phi) * e1 + std::sin(phi) * e2;
        s = a + rng.uniform() * (b - a) + r * nrm;
      } else {  // a hemisphere: a uniform direction, at the end it points away from
        do nrm = Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
        while (nrm.squaredNorm() > 1.0 || nrm.squaredNorm() < 1e-6);
        nrm.normalize();
        s = (nrm.dot(axis) < 0 ? a : b) + r * nrm;
      }
      double de = 0;
      human_body_distance(model, cap, 0.0, s.data(), nullptr, &de);
      if (de < -1e-9) continue;  // buried in another capsule: not on the body's surface
      ++accepted;
      for (double e : cfg.epsilons) push(s + e * nrm, true);
    }
    const int nvol = int(std::lround(cfg.volume_fraction * accepted * double(cfg.epsilons.size())));
    const Eigen::Vector3d vm = Eigen::Vector3d::Constant(cfg.volume_margin), vlo = lo3 - vm, vhi = hi3 + vm;
    for (int i = 0; i < nvol; ++i)
      push({rng.uniform(vlo.x(), vhi.x()), rng.uniform(vlo.y(), vhi.y()), rng.uniform(vlo.z(), vhi.z())}, false);
  }
  return out;
}

}  // namespace atacom
