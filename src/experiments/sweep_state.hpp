// Where a sweep stands, read from the files its runs leave behind (the run
// directories are the truth; everything else is a view of them):
//   DIR/spec.json            the spec (a rerun must give the same one)
//   DIR/runs/<env>/<algo>/seed-<s>/   one `atacom train` run directory per cell
//   DIR/inputs/<cell>.json   the `atacom train --config` file of each cell
//   DIR/logs/<cell>.log      stdout + stderr of every attempt (appended)
//   DIR/state/<cell>.json    the last attempt: state, exit code, host, pid
//   DIR/state/<cell>.lock    flock-ed by the process that runs the cell
//   DIR/sweep.json           every cell's state, rebuilt every few seconds and at the end
// A cell is "done" when its summary.json covers the spec's steps (or says
// the run stopped at its quality target), "partial"
// when it holds a checkpoint to resume from, "running" while some process
// holds its lock, "failed" when the last attempt exited non-zero (with the
// log path), "interrupted" when an attempt died without saying so (kill -9,
// power loss), else "pending".
//
// A sweep directory may come from someone else: every file of it is read
// through no symlink (src/core/fs_util.hpp, read_below), as a regular file
// of at most a fixed size, and a file that is not what it should be (wrong
// JSON types, numbers out of range) reads as absent, never as an exception.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/experiments/sweep_spec.hpp"

namespace atacom {

// Size caps of the files of a sweep directory (docs/security.md).
constexpr size_t kMaxCellStateBytes = size_t{64} << 10;  // state/<cell>.json
constexpr size_t kMaxSummaryBytes = size_t{16} << 20;    // a run's summary.json
constexpr size_t kMaxProgressBytes = size_t{64} << 20;   // a run's progress.csv (the report reads it whole)
constexpr size_t kProgressTailBytes = size_t{64} << 10;  // what status reads of it: the last row
constexpr int kMaxAttempts = 1'000'000'000;

// The last attempt of a cell, as DIR/state/<cell>.json records it.
struct CellRecord {
  std::string state;  // running | done | failed | interrupted ("" when unknown)
  int attempts = 0;   // in [0, kMaxAttempts]
  int exit_code = 0;  // of a failed attempt, in [-1, 255]
  std::string host;   // at most 255 printable bytes
};
// The record in `text`, or nullopt when it is not one (not JSON, not an
// object, a key of the wrong type or out of range, an unknown state).
std::optional<CellRecord> parse_cell_record(std::string_view text);
// The cell's record; an absent or unreadable file reads as no record ({}).
CellRecord read_cell_record(const std::string& sweep_dir, const SweepCell& c);
void write_cell_state(const std::string& sweep_dir, const SweepCell& c, const nlohmann::json& state);

struct CellStatus {
  std::string state;          // done | running | partial | failed | interrupted | pending
  int64_t env_steps = 0;      // of the run's last progress row (or summary)
  int exit_code = 0;          // of the last failed attempt
  std::string host;           // where the last attempt ran
  int attempts = 0;
};

// Files only: "done", "partial" (checkpoint.bin to resume from) or "fresh".
std::string run_files_state(const std::string& sweep_dir, const SweepCell& c);
// env_steps of the last row of the cell's progress.csv (0 when there is none
// or it cannot be read).
int64_t run_progress_steps(const std::string& sweep_dir, const SweepCell& c);

std::string cell_state_path(const std::string& sweep_dir, const SweepCell& c, const char* ext);
std::string cell_state_rel(const SweepCell& c, const char* ext);  // "state/<cell><ext>"
std::string cell_log_path(const SweepCell& c);  // "logs/<cell>.log"

// True when another process holds the cell's lock (it is running there).
bool cell_locked_elsewhere(const std::string& sweep_dir, const SweepCell& c);

CellStatus cell_status(const std::string& sweep_dir, const SweepCell& c);
// cell_status of every cell, in order. Listings of state/ and of each
// runs/<env>/<algo>/ find the cells with files; the others are pending
// without a syscall each (measured in docs/sweeps.md, "How many cells").
std::vector<CellStatus> cell_statuses(const std::string& sweep_dir, const std::vector<SweepCell>& cells);

// One row of sweep.json: {name, env, algo, seed, dir, state, env_steps, steps, log, attempts[, exit_code][, host]}.
nlohmann::json sweep_row(const SweepCell& c, const CellStatus& st);
// {"updated_utc", "counts": {state: n}, "runs": [sweep_row...]}
nlohmann::json sweep_table(const std::string& sweep_dir, const std::vector<SweepCell>& cells);
// sweep.json from statuses at hand (one per cell), written row by row (no
// JSON tree of the whole table in memory).
void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells,
                      const std::vector<CellStatus>& statuses);
// The same from every cell's files (a full scan).
void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells);
// The table `atacom sweep status` prints.
std::string sweep_status_text(const nlohmann::json& table);

// The subdirectories of a sweep directory (inputs, logs, state, runs, slurm,
// report): created when missing; a symlink or a file in their place is refused
// (std::invalid_argument naming it), so nothing is written through one.
void prepare_sweep_dirs(const std::string& sweep_dir);

// DIR/spec.json: created exclusively on the first run (of two sweeps starting
// at once on an empty directory exactly one writes it), compared on every
// later one (a different spec in the same directory is an error).
void save_or_check_spec(const std::string& sweep_dir, const SweepSpec& s);
SweepSpec load_sweep_spec(const std::string& sweep_dir);

std::string utc_now();

}  // namespace atacom
