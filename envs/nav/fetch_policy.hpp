// The Fetch robot's hand-crafted go-to-goal controller (NavEnv's moving
// obstacle; reference digest section 4.3.6). Fetch ignores TIAGo: it turns
// towards its goal, drives forward with a speed proportional to the distance,
// slows down when it heads out towards a wall, and asks for a new goal once it
// sits on the current one facing it.
#pragma once
#include <nlohmann/json_fwd.hpp>

namespace atacom {

struct FetchPolicyParams {
  double k_v = 0.5;          // v = k_v |e|, 1/s
  double v_max = 0.7;        // |v| cap, m/s
  double k_w = 1.0;          // omega = k_w * heading error, 1/s
  double w_max = 1.5;        // |omega| cap, rad/s
  double goal_tol = 0.1;     // arrival: |e| < goal_tol ...
  double heading_tol = 0.1;  // ... and |heading error| < heading_tol (rad)
  double slow_x = 2.6;       // slow-down zone: |x| > slow_x or |y| > slow_y
  double slow_y = 1.6;       //   while heading outwards on that axis
  double slow_width = 0.5;   // v scale falls linearly to 0 this far past the zone edge, m
};

// The one default factory (values of the paper's navigation env).
FetchPolicyParams default_fetch_policy_params();
// Throws std::invalid_argument naming the first bad field.
void validate(const FetchPolicyParams& p);
void to_json(nlohmann::json& j, const FetchPolicyParams& p);
void from_json(const nlohmann::json& j, FetchPolicyParams& p);  // strict: every key, no unknown key

struct FetchCommand {
  double v = 0.0;        // forward speed, m/s (never negative: Fetch only drives forward)
  double w = 0.0;        // yaw rate, rad/s
  bool arrived = false;  // on the goal and facing it: the caller draws a new goal
};

// Command for a Fetch at pose (x, y, theta) driving to goal (gx, gy).
// Pure function of its inputs; no allocation.
FetchCommand fetch_command(const FetchPolicyParams& p, const double* pose, const double* goal);

// Shortest signed angle equal to a modulo 2 pi, in [-pi, pi].
double wrap_angle(double a);

}  // namespace atacom
