// What a sweep will cost before it runs (`atacom sweep --dry-run`): each
// cell's CPU seconds from measured rates (data/sweep_rates.json, written by
// bench/sweep_rates.sh, which records its command, CPU and date), summed.
//
// A learner's cell: the steps before updates start (sac.initial_replay) at
// the collect rate, the rest at the training rate, plus every evaluation
// (ceil(steps / eval_every) of them) as eval_episodes full-horizon episodes
// at the evaluation rate; a cell that does not learn: one evaluation.
// Episodes that end early make the real cost lower (the evaluation part is
// an upper bound). Rates are env steps per CPU second of a one-thread run;
// another CPU, other network sizes or updates_per_step change them.
#pragma once
#include <string>
#include <vector>

#include "src/sweep/sweep_spec.hpp"

namespace atacom {

struct SweepCost {
  double run_seconds = 0;     // the cells' seconds at one thread each, summed
  int unknown = 0;            // cells of an env/layer without a measured rate (not in run_seconds)
  std::string source;         // where the rates come from ("<cpu>, <date>: <command>")
};

// Throws std::runtime_error when the rates file cannot be read.
SweepCost estimate_sweep_cost(const std::vector<SweepCell>& cells);
// The same for cells[k], k in `which` (a dry run's cells still to run, no copies).
SweepCost estimate_sweep_cost(const std::vector<SweepCell>& cells, const std::vector<size_t>& which);
// One cell's seconds (NaN without a measured rate).
double estimate_cell_seconds(const SweepCell& cell);

}  // namespace atacom
