// The env a safety layer can wrap: control-affine dynamics and constraint rows.
//
// A ControlAffineEnv exposes, for its current state, the pieces of
// qdot = f(q) + G(q) a and of its constraints c(q, x) <= 0 (with J_q, J_x and
// xdot of the uncontrollable state). Every safety layer (the table of
// include/atacom/safety_layer.hpp) reads them; the same env runs unwrapped for plain RL.
#pragma once
#include <vector>

#include "atacom/env.hpp"
#include "atacom/projector.hpp"

namespace atacom {

class ControlAffineEnv : public BatchEnv {
 public:
  // Dimensions and per-row slack settings; K_c defaults to 1/dt.
  virtual ProjectorModel projector_model() const = 0;
  // Write f, G, c, Jq, Jx, xdot of the current state of envs [begin, end)
  // into pb (sized for model and N). Must not allocate; may run concurrently
  // on disjoint ranges.
  virtual void constraint_model(ProjectorBatch& pb, int begin, int end) const = 0;
};

}  // namespace atacom
