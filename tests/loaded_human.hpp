// The default human model (data/human), loaded once per test process: the
// fixture the human tests share.
#pragma once
#include "envs/arm/human_model.hpp"

inline const atacom::HumanModel& human_model() {
  static const atacom::HumanModel m = atacom::load_human_model();
  return m;
}
