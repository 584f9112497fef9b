// Per-env state of N navigation envs, structure of arrays. Written only by
// the kernels of envs/nav/nav_kernels.hpp (reset, place, step) and by
// snapshot loading; the static model is NavModel (envs/nav/nav_model.hpp).
// Poses are the Box2D bodies' float values widened to double; Box2D holds no
// other state a step depends on, so this batch is the env's whole state.
#pragma once
#include <cstdint>
#include <vector>

#include "atacom/rng.hpp"

namespace atacom {

struct NavBatch {
  int N = 0;
  // Episode state, written by reset (start of an episode) and step.
  std::vector<double> tiago;        // (N x 3) TIAGo x, y, theta (theta unwrapped, as Box2D integrates it)
  std::vector<double> tiago_vel;    // (N x 3) world vx, vy, omega TIAGo moved with in the last step (0 at a start)
  std::vector<double> fetch;        // (N x 3) Fetch x, y, theta
  std::vector<double> fetch_vel;    // (N x 3) world vx, vy, omega Fetch moves with in the next step
  std::vector<double> fetch_cmd;    // (N x 2) Fetch v, omega for the next step (its controller at this state)
  std::vector<double> goal;         // (N x 2) TIAGo goal; reset
  std::vector<double> fetch_goal;   // (N x 2) Fetch goal; reset, and step when Fetch reaches it
  std::vector<double> prev_action;  // (N x 2) last normalised action applied (0 after reset)
  std::vector<int32_t> t;           // (N) steps taken in the current episode
  std::vector<double> ret;          // (N) undiscounted return of the current episode so far
  std::vector<Rng> rng;             // (N) stream (seed, env id); reset draws starts and goals, step Fetch's goals
  // Step scratch, written and read inside one env range of nav_step_range.
  std::vector<double> act;          // (N x 2) the action as applied: NaN -> 0, clipped to [-1, 1]
  std::vector<uint8_t> nan;         // (N) the action had a NaN component
  std::vector<uint8_t> hit_wall;    // (N) TIAGo-wall contact at the reached state
  std::vector<uint8_t> hit_fetch;   // (N) TIAGo-Fetch contact at the reached state

  // Sizes every array for n envs (values zero, streams unseeded).
  void resize(int n);
};

}  // namespace atacom
