// A sweep as Slurm job arrays: `atacom sweep SPEC --out DIR --slurm ...`.
//
// Submitting groups the cells that are not done into tasks of
// --runs-per-task cells, writes DIR/slurm/<submission>/tasks.json and one
// sbatch script per array (arrays larger than the cluster's MaxArraySize are
// split), submits them (`sbatch --parsable`), prints the job ids and records
// them in DIR/slurm/jobs.json. A later submission refuses while an earlier
// job of the sweep is still queued or running, and submits only the cells
// that are not done.
//
// Each task runs `atacom sweep DIR/spec.json --out DIR --slurm-task FILE
// --task-offset O` (the cells of task O + SLURM_ARRAY_TASK_ID, with the
// task's cores: SLURM_CPUS_PER_TASK, else SLURM_CPUS_ON_NODE) under a bash
// wrapper: on the pre-timeout signal (--signal=B:USR1@S) it forwards USR1,
// every run writes a checkpoint and exits, and the task requeues itself
// (`scontrol requeue ${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}`: the task, not the
// array); the requeued task resumes them bitwise. Tested on a real one-node Slurm:
// tests/slurm/ (ctest label slurm) and docs/sweeps.md.
#pragma once
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/experiments/sweep_spec.hpp"

namespace atacom {

struct SlurmOptions {
  std::string partition, time, mem, account;
  int cpus_per_task = 1;
  int max_parallel = 0;          // %K of --array (0: no limit)
  int runs_per_task = 1;
  int presignal_s = 120;         // --signal=B:USR1@<this>
  std::vector<std::string> sbatch_args;  // extra "#SBATCH <arg>" lines
  std::string exe;               // the atacom binary the tasks run (absolute; nodes must see it)
};

// The script of one array of `tasks` tasks starting at task `offset`.
std::string slurm_array_script(const std::string& dir, const std::string& sub_dir, const std::string& tasks_file,
                               int offset, int tasks, const SlurmOptions& o);

// Seconds of a Slurm time limit (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS);
// -1 for UNLIMITED / INFINITE. Throws std::invalid_argument naming --time otherwise.
long slurm_time_seconds(const std::string& t);

// Submits; returns the job ids. A --time that leaves no work before the signal
// (Slurm may send it up to 60 s before --presignal asks) is refused. Throws std::runtime_error naming the failing command.
std::vector<std::string> submit_sweep_slurm(const SweepSpec& spec, const std::string& dir, const SlurmOptions& o,
                                            std::ostream& log);

// For `atacom sweep status`: every run of `table` (sweep_table) that is not done and
// was submitted gets "slurm_task" ("<array job>_<index>" of the latest submission
// holding it) and "slurm_log" (that task's log, relative to the sweep directory).
// No-op for a sweep never submitted.
void add_slurm_tasks(const std::string& dir, nlohmann::json& table);

// The cells of task (offset + SLURM_ARRAY_TASK_ID) of a tasks file.
std::vector<size_t> slurm_task_cells(const std::string& tasks_file, int offset);

}  // namespace atacom
