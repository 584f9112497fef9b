// The state files of a received sweep directory (what `atacom sweep`, `sweep
// status` and `report` read besides the runs): the first byte of the input
// chooses the file, the rest is its content:
//   0: state/<cell>.json   (a cell's last attempt)
//   1: slurm/jobs.json     (the submissions)
//   2: slurm/submit-x/tasks.json (a submission's cells, named by a valid jobs.json)
// A cell state file never raises anything: it is a record with every number
// in range, or it reads as no record. The Slurm files give a status table or
// a std::invalid_argument with a printable message. Either way the status
// table and its text are made, every count adds up, and nothing else escapes
// (no bare nlohmann type_error, no bad_alloc, no crash, no hang).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "src/sweep/sweep_slurm.hpp"
#include "src/sweep/sweep_spec.hpp"
#include "src/sweep/sweep_state.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace fs = std::filesystem;

namespace {

void check_printable(const char* msg) {
  for (const char* p = msg; *p; ++p)
    if (static_cast<unsigned char>(*p) < 0x20 || static_cast<unsigned char>(*p) >= 0x7f)
      fuzz_fail("raw byte in an error message:", msg);
}

// Memory-backed when the machine has it: every execution writes and fsyncs
// several files, which on a disk costs more than the parsing under test.
fs::path scratch_dir() {
  std::error_code ec;
  if (fs::is_directory("/dev/shm", ec) && ::access("/dev/shm", W_OK) == 0) return "/dev/shm";
  return fs::temp_directory_path();
}

struct SweepDir {
  fs::path dir = scratch_dir() / ("atacom_fuzz_sweep_state_" + std::to_string(::getpid()));
  atacom::SweepSpec spec;
  std::vector<atacom::SweepCell> cells;
  SweepDir() {
    fs::remove_all(dir);
    spec = atacom::parse_sweep_spec(
        nlohmann::json::parse(R"({"envs": ["table"], "algos": ["la", "sac"], "seeds": [0, 1], "steps": 1000})"));
    atacom::save_or_check_spec(dir.string(), spec);
    atacom::prepare_sweep_dirs(dir.string());
    cells = atacom::sweep_cells(spec);
  }
  ~SweepDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const SweepDir& sweep_dir() {
  static const SweepDir d;
  return d;
}

void write(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary | std::ios::trunc) << text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const SweepDir& S = sweep_dir();
  const std::string dir = S.dir.string();
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  const int which = data[0] % 3;
  std::error_code ec;
  fs::remove_all(S.dir / "slurm", ec);
  fs::remove(S.dir / "state" / (S.cells[0].name() + ".json"), ec);
  if (which == 0) {
    // Straight from the bytes: never throws, every number in range.
    if (const auto r = atacom::parse_cell_record(text)) {
      if (r->attempts < 0 || r->attempts > atacom::kMaxAttempts) fuzz_fail("attempts out of range");
      if (r->exit_code < -1 || r->exit_code > 255) fuzz_fail("exit_code out of range");
      check_printable(r->host.c_str());
    }
    write(S.dir / "state" / (S.cells[0].name() + ".json"), text);
  } else if (which == 1) {
    write(S.dir / "slurm" / "jobs.json", text);
  } else {
    write(S.dir / "slurm" / "jobs.json",
          R"([{"job_id": "17", "tasks_file": "/elsewhere/slurm/submit-x/tasks.json", "offset": 0, "tasks": 2}])");
    write(S.dir / "slurm" / "submit-x" / "tasks.json", text);
  }
  try {
    const atacom::CellRecord rec = atacom::read_cell_record(dir, S.cells[0]);  // never throws
    if (rec.attempts < 0 || rec.attempts > atacom::kMaxAttempts) fuzz_fail("attempts out of range (file)");
    nlohmann::json table = atacom::sweep_table(dir, S.cells);
    if (which != 0) {
      try {
        atacom::add_slurm_tasks(dir, table);
      } catch (const std::invalid_argument& e) {
        check_printable(e.what());
      }
    }
    const std::string shown = atacom::sweep_status_text(table);
    int total = 0;
    for (auto it = table.at("counts").begin(); it != table.at("counts").end(); ++it) total += it.value().get<int>();
    if (total != int(S.cells.size())) fuzz_fail("the status counts do not add up to the cells");
    check_printable(shown.substr(0, shown.find('\n')).c_str());
  } catch (const std::exception& e) {
    fuzz_fail("a sweep state file escaped as an exception:", e.what());
  }
  return 0;
}
