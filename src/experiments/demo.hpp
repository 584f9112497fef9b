// `atacom demo`: thousands of differential-drive robots explore a room with
// a pillar and a moving disc under a random policy, once through ATACOM and
// once without, from the same seeds. Shows in seconds what the projector
// does: the same exploration, no collisions.
#pragma once
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace atacom {

struct DemoConfig {
  int envs = 2048;       // robots
  int steps = 900;       // control steps per robot (30 Hz: 30 s)
  uint64_t seed = 0;
  int trajectories = 8;  // robots drawn in the SVG
};

DemoConfig default_demo_config();
void to_json(nlohmann::json& j, const DemoConfig& c);
void from_json(const nlohmann::json& j, DemoConfig& c);  // strict

struct DemoResult {
  nlohmann::json summary;  // per mode: steps, collisions, max_constraint, per_s, ...
  std::string svg;         // trajectories with and without ATACOM
};

DemoResult run_demo(const DemoConfig& config);

}  // namespace atacom
