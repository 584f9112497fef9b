// Constraint row groups of the manipulation envs. An env composes its rows
// from groups in a fixed order, and k follows from the groups it has:
//
//   group    rows  c(q, x) <= 0                                   J_q                J_x (x = human time)
//   joint    14    (lower+margin) - q, q - (upper-margin)          -/+ e_j            0
//   scene     9    delta_i - d_scene(p_i(q))      [static scene]   -grad d . J_poi    0
//   body      9    delta_i - d_body(p_i(q))       [robot body]     -grad d . J_poi    0
//   ground    2    h_i - z(p_i(q))                                 -e_z . J_poi       0
//   human     9    delta_i - smin_caps d(p_i(q), t)  [moving]      -grad d . J_poi    dc/dt (xdot = 1)
//   upright   1    cos(theta_max - margin) - u_z(q)  [cup axis u]  -(w_j x u)_z       0
//
// TableEnv and ShelfEnvSim compose joint, scene, body, ground (k = 34);
// HRI-Sim adds human (k = 43, p = 1), hri-upright also upright (k = 44). The
// first 34 rows keep their positions in every env, so the static rows'
// kernels, caches and tests are shared.
//
// Seam for learned distance fields ("distance to a static scene object"):
// the scene group's d and grad d come from one function,
// lanes::arm_scene_distance_lanes (kernels/arm_env_kernel.hpp), and its
// scalar twin arm_scene_distance_reference (envs/arm/arm_reference.cpp).
// A learned SDF replaces those two bodies (values and gradients per PoI, in
// base_footprint); nothing else reads the scene's shapes for the rows (the
// ground-truth check keeps the exact geometry).
#pragma once
#include <string>
#include <vector>

#include "envs/arm/tiago_model.hpp"

namespace atacom {

enum class ArmRowKind : uint8_t { Joint = 0, Scene = 1, Body = 2, Ground = 3, Human = 4, Upright = 5 };

inline constexpr int kArmRows = 34;  // rows of the static groups (joint, scene, body, ground)
inline constexpr int kRowJointLower = 0;
inline constexpr int kRowJointUpper = 7;
inline constexpr int kRowScene = 14;
inline constexpr int kRowBody = 23;
inline constexpr int kRowGround = 32;
inline constexpr int kRowHuman = 34;                                 // when composed
inline constexpr int kRowUpright = kRowHuman + kArmPoi;              // 43, when composed (hri-upright)
inline constexpr int kArmMaxRows = kRowUpright + 1;                  // 44
inline constexpr int kArmDynamicRows = kArmRows - kRowScene;         // q-dependent Jacobian rows of the static groups
inline constexpr int kArmMaxDynamicRows = kArmMaxRows - kRowScene;   // 30

// A group of rows. A moving group's rows also depend on an obstacle that
// moves on its own (HRI: the human): the batch carries that obstacle's state
// and velocity (ArmMovingObstacle, envs/arm/arm_batch.hpp), and the group
// owns one uncontrollable state x of the projector (its obstacle's clock,
// column `state` of J_x) for which it writes J_x = dc/dt and xdot = 1.
struct ArmRowSpan {
  ArmRowKind kind;
  int begin = 0, count = 0;
  bool moving = false;
  int state = -1;  // moving: its column of J_x / index into xdot
};

// The rows an env composes; k, offsets and the dynamic-row count follow.
struct ArmRowLayout {
  std::vector<ArmRowSpan> groups;
  int k = 0;
  int p = 0;  // moving groups = uncontrollable states of the projector

  // The static groups, plus the human rows for the HRI task and the upright
  // row when asked for (hri-upright).
  static ArmRowLayout compose(bool hri, bool upright = false) {
    ArmRowLayout l;
    auto add = [&](ArmRowKind kind, int n, bool moving = false) {
      l.groups.push_back({kind, l.k, n, moving, moving ? l.p++ : -1});
      l.k += n;
    };
    add(ArmRowKind::Joint, 2 * kArmJoints);
    add(ArmRowKind::Scene, kArmPoi);
    add(ArmRowKind::Body, kArmPoi);
    add(ArmRowKind::Ground, 2);
    if (hri) {
      add(ArmRowKind::Human, kArmPoi, /*moving=*/true);
      if (upright) add(ArmRowKind::Upright, 1);
    }
    return l;
  }
  bool has(ArmRowKind kind) const {
    for (const ArmRowSpan& g : groups)
      if (g.kind == kind) return true;
    return false;
  }
  int moving_groups() const { return p; }
  int dynamic_rows() const { return k - kRowScene; }  // rows whose J_q depends on q (all but the joint group)
};

}  // namespace atacom
