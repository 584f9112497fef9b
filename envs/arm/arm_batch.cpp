#include "envs/arm/arm_batch.hpp"

#include <cmath>
#include <stdexcept>

#include "envs/arm/arm_model.hpp"

namespace atacom {

void ArmBatch::resize(const ArmModel& m, int n) {
  N = n;
  const size_t sn = static_cast<size_t>(n);
  q.assign(sn * kArmJoints, 0.0);
  goal.assign(sn * 3, 0.0);
  t.assign(sn, 0);
  ret.assign(sn, 0.0);
  rng.assign(sn, Rng());
  fallback.assign(sn, 0);
  c.assign(sn * size_t(m.k), 0.0);
  J.assign(((sn + lanes::kLanes - 1) / lanes::kLanes) * lanes::kLanes * size_t(m.dyn) * kArmJoints, 0.0);
  grasp.assign(sn * 3, 0.0);
  approach.assign(sn * 3, 0.0);
  if (!m.hri()) return;
  human.t.assign(sn, 0.0);
  human.body.resize(n);
  human.Jx.assign(sn * kArmPoi, 0.0);
  human.final_cap.assign(sn * kHumanCapsules * 6, 0.0);
  cup.assign(sn * 3, 0.0);
  min_hd.assign(sn, INFINITY);
  spilled.assign(sn, 0);
  items.assign(sn * m.kern.items.size() * 6, 0.0);
  contact.assign(sn, 0);
  hd.assign(sn, 0.0);
}

const ArmMovingObstacle& ArmBatch::moving(const ArmRowSpan& g) const {
  if (g.kind == ArmRowKind::Human) return human;
  throw std::logic_error("arm row group " + std::to_string(int(g.kind)) + " has no moving obstacle");
}

}  // namespace atacom
