// What a sweep will cost before it runs (`atacom sweep --dry-run`): each
// cell's CPU seconds from measured rates (data/sweep_rates.json, written by
// bench/sweep_rates.sh, which records its command, CPU and date), summed.
//
// A learner's cell: every step at the collect rate, and the steps after
// sac.initial_replay with the update seconds the rates imply (training minus
// collect) for SAC with the env's paper-preset settings, scaled by the
// learner's work per env step against that reference (updates per step,
// batch, network sizes; PPO's epochs; the Lagrangian's cost critics), plus
// every evaluation (ceil(steps / eval_every) of them) as eval_episodes
// full-horizon episodes at the evaluation rate; a cell that does not learn:
// one evaluation. Episodes that end early make the real cost lower (the
// evaluation part is an upper bound). Rates are env steps per CPU second of a
// one-thread run on the CPU the file names; CBF takes SafeLayer's rates.
#pragma once
#include <string>
#include <vector>

#include "src/experiments/sweep_spec.hpp"

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
