// Running a sweep's cells on this machine: K `atacom train` child processes
// at a time (each a fresh process of the same binary, so one run crashing or
// being killed never takes the sweep down), T threads each.
//
// Every start looks at the run files first (src/experiments/sweep_state.hpp): a
// done cell is skipped, a cell with a checkpoint resumes (`train --resume`),
// any other is started from an empty directory (a run killed before its
// first checkpoint has nothing to continue from, and restarting it from
// step 0 gives the same bits). A cell is locked (flock) while it runs, so
// two sweeps on the same directory (shards, or a second shell) never run one
// cell twice. Killed at any moment, the next invocation ends with the same
// run files as an uninterrupted sweep.
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

#include "src/experiments/sweep_spec.hpp"

namespace atacom {

struct SweepLocalOptions {
  std::string dir;                   // the sweep directory (--out)
  std::string exe = "/proc/self/exe";  // the atacom binary the runs execute
  int jobs = 0;                      // runs at a time (0: default_sweep_jobs)
  int threads_per_run = 0;           // 0: cores / jobs (at least 1)
  Shard shard;
  std::vector<size_t> cells;         // non-empty: exactly these cells (a Slurm task's), not the shard's
  bool dry_run = false;
  std::ostream* log = nullptr;       // progress line target
  bool log_is_tty = false;
};

// Cores this process may use: SLURM_CPUS_PER_TASK, else SLURM_CPUS_ON_NODE,
// else the CPUs of its affinity mask.
int available_cores();
// The measured faster split on 2 cores is one thread per run (docs/sweeps.md):
// as many runs at a time as cores.
int default_sweep_jobs();

// Returns 0 when every cell of the shard is done, 1 when some failed, 130
// when stopped by SIGINT/SIGTERM (children are stopped too; rerun to go on),
// 75 on SIGUSR1 (every run wrote a checkpoint and exited: requeue).
int run_sweep_local(const SweepSpec& spec, const SweepLocalOptions& opts);

}  // namespace atacom
