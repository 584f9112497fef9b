// What `atacom report` reads of a run directory it did not write: the input
// is "<summary.json>\n===\n<progress.csv>" for the first run of a two-run
// sweep directory (the second run's files are fixed and valid), optionally
// followed by "\n===\n<summary.json>\n===\n<progress.csv>" of the second.
// The report is written or refused with a std::invalid_argument whose
// message is printable; it always ends (libFuzzer's -timeout catches a
// hang), and no figure holds a NaN or infinite coordinate.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "src/report/report.hpp"
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
  fs::path dir = scratch_dir() / ("atacom_fuzz_report_" + std::to_string(::getpid()));
  std::vector<atacom::SweepCell> cells;
  SweepDir() {
    fs::remove_all(dir);
    const atacom::SweepSpec spec = atacom::parse_sweep_spec(
        nlohmann::json::parse(R"({"envs": ["table"], "algos": ["atacom-sac"], "seeds": [0, 1], "steps": 1000})"));
    atacom::save_or_check_spec(dir.string(), spec);
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

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

const char* kValidSummary =
    R"({"env_steps": 1000, "eval_return_mean": -12.5, "eval_discounted_return_mean": -8, "final_distance": 0.2,
        "train_avg_episode_steps": 480, "train_collisions": 3, "best": {"eval_return_mean": -10, "env_steps": 500}})";
const char* kValidProgress = "env_steps,updates,wall_s,eval_return_mean,final_distance\n500,10,0.1,-10,0.3\n1000,20,0.2,-12.5,0.2\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const SweepDir& S = sweep_dir();
  const std::string in(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  for (size_t at = 0;;) {
    const size_t sep = in.find("\n===\n", at);
    parts.push_back(in.substr(at, sep == std::string::npos ? std::string::npos : sep - at));
    if (sep == std::string::npos || parts.size() == 4) break;
    at = sep + 5;
  }
  const bool second_given = parts.size() >= 3;
  parts.resize(4);
  if (!second_given) {
    parts[2] = kValidSummary;
    parts[3] = kValidProgress;
  }
  std::error_code ec;
  fs::remove_all(S.dir / "runs", ec);
  fs::remove_all(S.dir / "report", ec);
  for (size_t k = 0; k < 2; ++k) {
    const fs::path run = S.dir / S.cells[k].run_dir();
    write(run / "summary.json", parts[2 * k]);
    write(run / "progress.csv", parts[2 * k + 1]);
  }
  atacom::ReportOptions o;
  o.dir = S.dir.string();
  o.resamples = 100;
  o.curve_resamples = 10;
  try {
    atacom::write_report(o);
  } catch (const std::invalid_argument& e) {
    check_printable(e.what());
    return 0;
  } catch (const std::exception& e) {
    fuzz_fail("report inputs escaped as an exception that is not an input error:", e.what());
  }
  static const std::regex nonfinite(R"re(="[^"]*(nan|inf)[^"]*")re", std::regex::icase);
  for (const char* f : {"box_table.svg", "curves_table.svg"}) {
    const std::string svg = slurp(S.dir / "report" / f);
    if (std::regex_search(svg, nonfinite)) fuzz_fail("a NaN or infinite coordinate in", f);
  }
  return 0;
}
