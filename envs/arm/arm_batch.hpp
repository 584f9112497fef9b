// Per-env state of N manipulation envs, structure of arrays. Written only by
// the kernels of envs/arm/arm_kernels.hpp (reset, step, refresh) and by
// snapshot loading; the static model is ArmModel (envs/arm/arm_model.hpp).
#pragma once
#include <cstdint>
#include <vector>

#include "atacom/rng.hpp"
#include "envs/arm/arm_rows.hpp"
#include "kernels/human_kernels.hpp"

namespace atacom {

struct ArmModel;

// The obstacle of a moving row group, per env: its state and velocity, and
// the rows' J_x. HRI: the human. Its clock is the uncontrollable state x of
// the projector (x = env time of the motion, xdot = 1 per second), so
// J_x = dc/dt of the group's rows.
struct ArmMovingObstacle {
  std::vector<double> t;      // (N)              motion time, frames; reset (episode start), step (+frames_per_step)
  HumanBatch body;            // (N)              pose, pose_rate (its velocity), capsules and capsule velocities at t;
                              //                  written by arm_human_at() whenever t changes
  std::vector<double> Jx;     // (N x rows)       dc/dt of the group's rows; written with c (store_lane)
  std::vector<double> final_cap;  // (N x 16 x 6) capsules of an episode's last step (written on autoreset)
};

struct ArmBatch {
  int N = 0;
  uint64_t seed = 0;               // last seed() (the streams are keyed (seed, env id))
  // Episode state, written by reset and step.
  std::vector<double> q;           // (N x 7)   joint positions
  std::vector<double> goal;        // (N x 3)   goal position
  std::vector<int32_t> t;          // (N)       steps into the episode
  std::vector<double> ret;         // (N)       running undiscounted return
  std::vector<Rng> rng;            // (N)       per-env stream keyed (seed, env id)
  std::vector<uint8_t> fallback;   // (N)       1 if the last reset used a fallback (home or library goal)
  // Cached model of the current state (a pure function of q and the obstacle
  // state), written by store_lane in step, reset and refresh.
  std::vector<double> c;           // (N x k)   constraint values
  std::vector<double> J;           // (ceil(N/8) x dyn x 7 x 8) Jacobians of rows kRowScene..k-1,
                                   //           lane-major per group of 8 envs
  std::vector<double> grasp;       // (N x 3)   grasping-frame position
  std::vector<double> approach;    // (N x 3)   approach axis (grasping frame x)
  // HRI only (empty otherwise).
  ArmMovingObstacle human;         // the moving group's obstacle
  std::vector<double> cup;         // (N x 3)   cup axis; written with c
  std::vector<double> min_hd;      // (N)       smallest human distance so far in the episode; step, reset
  std::vector<uint8_t> spilled;    // (N)       bit 0: the episode spilled at spill_angle, bit 1 at spill_angle_strict; step, reset
  // Step scratch (HRI), written and read inside one lane group of step.
  std::vector<double> items;       // (N x items x 6) robot parts in the base frame (contact check)
  std::vector<uint8_t> contact;    // (N)       human contact of the last step
  std::vector<double> hd;          // (N)       robot-to-human distance of the last step

  // Sizes every array for N envs of model m (values zero, streams unseeded).
  void resize(const ArmModel& m, int N);
  // The obstacle of a moving row group (the human's for ArmRowKind::Human);
  // std::logic_error for a static group.
  const ArmMovingObstacle& moving(const ArmRowSpan& g) const;
};

}  // namespace atacom
