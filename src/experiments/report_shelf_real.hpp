// The ShelfEnvReal protocol (envs/arm/shelf_real.hpp, the paper's real-robot
// table) in the sweep report: every finished shelf run's final policy goes
// through it, with the run's env settings and the layer it trained through.
// All policies meet the same trials (protocol seed 0), so their rows compare
// pair for pair. Internal to src/experiments/.
#pragma once
#include <string>
#include <vector>

#include "envs/arm/shelf_real.hpp"
#include "src/experiments/report_data.hpp"

namespace atacom {

struct ShelfRealRun {
  const ReportRun* run = nullptr;
  std::string safety;   // the layer the protocol ran the policy through ("none", "atacom", "safelayer", "cbf")
  std::string skipped;  // why the run was not evaluated (empty: evaluated)
  ShelfRealResult result;
};

struct ShelfRealAlgo {
  std::string algo, safety;
  bool attractor = false;  // one deterministic evaluation stands for every seed
  size_t n = 0;            // evaluated policies
  std::vector<double> success[2], error[2];  // per policy, target 1 and 2
  std::vector<double> collisions;             // per policy, both targets
  int violation_steps = 0;                    // summed over policies
  int total_collisions() const;
};

struct ShelfRealSection {
  ShelfRealConfig protocol;
  std::vector<ShelfRealRun> runs;   // finished shelf runs, sweep order (an attractor's first run only)
  std::vector<ShelfRealAlgo> algos; // spec order, algorithms with an evaluated run
};

// Empty (no runs) when the sweep has no finished shelf run. Learner runs
// through a layer other than ATACOM or none are listed as skipped (the
// protocol projects through ATACOM or nothing, as the paper's robot did), as
// are runs whose policy file is missing (a sweep copied without policies).
ShelfRealSection shelf_real_section(const ReportData& d);

// The bootstrap stream key of an algorithm's ShelfEnvReal number ("success1",
// "error2", ...): the section's table and the paper's claims draw the same
// resamples for it.
std::string shelf_real_stream(const std::string& algo, const std::string& what);

}  // namespace atacom
