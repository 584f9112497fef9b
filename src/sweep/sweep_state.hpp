// Where a sweep stands, read from the files its runs leave behind (the run
// directories are the truth; everything else is a view of them):
//   DIR/spec.json            the spec (a rerun must give the same one)
//   DIR/runs/<env>/<algo>/seed-<s>/   one `atacom train` run directory per cell
//   DIR/inputs/<cell>.json   the `atacom train --config` file of each cell
//   DIR/logs/<cell>.log      stdout + stderr of every attempt (appended)
//   DIR/state/<cell>.json    the last attempt: state, exit code, host, pid
//   DIR/state/<cell>.lock    flock-ed by the process that runs the cell
//   DIR/sweep.json           every cell's state, rewritten as they change
// A cell is "done" when its summary.json covers the spec's steps (or says
// the run stopped at its quality target), "partial"
// when it holds a checkpoint to resume from, "running" while some process
// holds its lock, "failed" when the last attempt exited non-zero (with the
// log path), "interrupted" when an attempt died without saying so (kill -9,
// power loss), else "pending".
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/sweep/sweep_spec.hpp"

namespace atacom {

struct CellStatus {
  std::string state;          // done | running | partial | failed | interrupted | pending
  int64_t env_steps = 0;      // of the run's last progress row (or summary)
  int exit_code = 0;          // of the last failed attempt
  std::string log;            // relative to the sweep directory
  std::string host;           // where the last attempt ran
  int attempts = 0;
};

// Files only: "done", "partial" (checkpoint.bin to resume from) or "fresh".
std::string run_files_state(const std::string& sweep_dir, const SweepCell& c);
// env_steps of the last row of progress.csv (0 when there is none).
int64_t run_progress_steps(const std::string& run_dir);

std::string cell_state_path(const std::string& sweep_dir, const SweepCell& c, const char* ext);
std::string cell_log_path(const SweepCell& c);  // "logs/<cell>.log"
nlohmann::json read_cell_state(const std::string& sweep_dir, const SweepCell& c);  // {} when none
void write_cell_state(const std::string& sweep_dir, const SweepCell& c, const nlohmann::json& state);

// True when another process holds the cell's lock (it is running there).
bool cell_locked_elsewhere(const std::string& sweep_dir, const SweepCell& c);

CellStatus cell_status(const std::string& sweep_dir, const SweepCell& c);

// {"spec", "updated_utc", "counts": {state: n}, "runs": [{name, env, algo, seed, dir, state, env_steps, steps, log, exit_code, host, attempts}]}
nlohmann::json sweep_table(const std::string& sweep_dir, const std::vector<SweepCell>& cells);
void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells);
// The table `atacom sweep status` prints.
std::string sweep_status_text(const nlohmann::json& table);

// DIR/spec.json: written on the first run, compared on every later one
// (a different spec in the same directory is an error).
void save_or_check_spec(const std::string& sweep_dir, const SweepSpec& s);
SweepSpec load_sweep_spec(const std::string& sweep_dir);

std::string utc_now();

}  // namespace atacom
