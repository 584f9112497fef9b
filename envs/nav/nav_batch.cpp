// NavBatch: sizing of the navigation env's per-env arrays.
#include "envs/nav/nav_batch.hpp"

namespace atacom {

void NavBatch::resize(int n) {
  N = n;
  const size_t s = static_cast<size_t>(n);
  tiago.assign(3 * s, 0.0);
  tiago_vel.assign(3 * s, 0.0);
  fetch.assign(3 * s, 0.0);
  fetch_vel.assign(3 * s, 0.0);
  fetch_cmd.assign(2 * s, 0.0);
  goal.assign(2 * s, 0.0);
  fetch_goal.assign(2 * s, 0.0);
  prev_action.assign(2 * s, 0.0);
  t.assign(s, 0);
  ret.assign(s, 0.0);
  rng.assign(s, Rng());
  act.assign(2 * s, 0.0);
  nan.assign(s, 0);
  hit_wall.assign(s, 0);
  hit_fetch.assign(s, 0);
}

}  // namespace atacom
