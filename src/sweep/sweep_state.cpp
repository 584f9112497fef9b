#include "src/sweep/sweep_state.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"

namespace fs = std::filesystem;

namespace atacom {

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof(b), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

int64_t run_progress_steps(const std::string& run_dir) {
  std::ifstream f(run_dir + "/progress.csv");
  std::string line, last;
  std::getline(f, line);  // header
  while (std::getline(f, line))
    if (!line.empty()) last = line;
  if (last.empty()) return 0;
  try {
    return std::stoll(last.substr(0, last.find(',')));
  } catch (const std::exception&) {
    return 0;
  }
}

std::string run_files_state(const std::string& sweep_dir, const SweepCell& c) {
  const fs::path run = fs::path(sweep_dir) / c.run_dir();
  if (fs::exists(run / "summary.json")) {
    try {
      const nlohmann::json s = read_json_file((run / "summary.json").string(), "summary file");
      // A run that stopped at its quality target (train.stop_at_target) is done before its budget.
      const nlohmann::json stopped = s.value("stopped_at_target", nlohmann::json(false));
      if (!c.learns || s.value("env_steps", int64_t{0}) >= c.steps || stopped == true) return "done";
    } catch (const std::exception&) {
      // unreadable: not done; the checkpoint decides
    }
  }
  if (c.learns && fs::exists(run / "checkpoint.bin") && fs::exists(run / "config.json")) return "partial";
  return "fresh";
}

std::string cell_state_path(const std::string& sweep_dir, const SweepCell& c, const char* ext) {
  return (fs::path(sweep_dir) / "state" / (c.name() + ext)).string();
}

std::string cell_log_path(const SweepCell& c) { return "logs/" + c.name() + ".log"; }

nlohmann::json read_cell_state(const std::string& sweep_dir, const SweepCell& c) {
  const std::string p = cell_state_path(sweep_dir, c, ".json");
  if (!fs::exists(p)) return nlohmann::json::object();
  try {
    return read_json_file(p, "cell state file");
  } catch (const std::exception&) {
    return nlohmann::json::object();  // atomic writes make this rare; the run files still decide "done"
  }
}

void write_cell_state(const std::string& sweep_dir, const SweepCell& c, const nlohmann::json& state) {
  fs::create_directories(fs::path(sweep_dir) / "state");
  write_file_atomic(cell_state_path(sweep_dir, c, ".json"), state.dump(2) + "\n");
}

bool cell_locked_elsewhere(const std::string& sweep_dir, const SweepCell& c) {
  const std::string p = cell_state_path(sweep_dir, c, ".lock");
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

CellStatus cell_status(const std::string& sweep_dir, const SweepCell& c) {
  CellStatus st;
  const std::string files = run_files_state(sweep_dir, c);
  const nlohmann::json rec = read_cell_state(sweep_dir, c);
  st.attempts = rec.value("attempts", 0);
  st.host = rec.value("host", "");
  st.log = cell_log_path(c);
  const std::string run = (fs::path(sweep_dir) / c.run_dir()).string();
  st.env_steps = run_progress_steps(run);
  if (files == "done") {
    st.state = "done";
    st.env_steps = c.learns ? std::max(st.env_steps, c.steps) : 0;
    return st;
  }
  const std::string last = rec.value("state", "");
  if (cell_locked_elsewhere(sweep_dir, c)) st.state = "running";
  else if (last == "failed") {
    st.state = "failed";
    st.exit_code = rec.value("exit_code", 0);
  } else if (last == "running") st.state = "interrupted";  // its process died without a word
  else st.state = files == "partial" ? "partial" : "pending";
  return st;
}

nlohmann::json sweep_table(const std::string& sweep_dir, const std::vector<SweepCell>& cells) {
  nlohmann::json runs = nlohmann::json::array();
  std::map<std::string, int> counts;
  for (const SweepCell& c : cells) {
    const CellStatus st = cell_status(sweep_dir, c);
    ++counts[st.state];
    nlohmann::json r = {{"name", c.name()}, {"env", c.env}, {"algo", c.algo}, {"seed", c.seed},
                        {"dir", c.run_dir()}, {"state", st.state}, {"env_steps", st.env_steps},
                        {"steps", c.learns ? c.steps : 0}, {"log", st.log}, {"attempts", st.attempts}};
    if (st.state == "failed") r["exit_code"] = st.exit_code;
    if (!st.host.empty()) r["host"] = st.host;
    runs.push_back(std::move(r));
  }
  return {{"updated_utc", utc_now()}, {"counts", counts}, {"runs", runs}};
}

void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells) {
  write_file_atomic((fs::path(sweep_dir) / "sweep.json").string(), sweep_table(sweep_dir, cells).dump(2) + "\n");
}

std::string sweep_status_text(const nlohmann::json& table) {
  std::ostringstream o;
  char b[512];
  std::snprintf(b, sizeof(b), "%-40s %-12s %21s %8s  %s\n", "run", "state", "env steps", "attempts", "log / dir");
  o << b;
  for (const auto& r : table.at("runs")) {
    const std::string steps = std::to_string(r.at("env_steps").get<int64_t>()) + "/" +
                              std::to_string(r.at("steps").get<int64_t>());
    std::string state = r.at("state").get<std::string>();
    if (state == "failed") state += " (" + std::to_string(r.at("exit_code").get<int>()) + ")";
    const bool show_log = state.rfind("failed", 0) == 0 || state == "interrupted";
    std::snprintf(b, sizeof(b), "%-40s %-12s %21s %8d  %s\n", r.at("name").get<std::string>().c_str(), state.c_str(),
                  steps.c_str(), r.at("attempts").get<int>(),
                  (show_log ? r.at("log") : r.at("dir")).get<std::string>().c_str());
    o << b;
    if (r.contains("slurm_log"))  // a submitted run that is not done: where its Slurm task logged
      o << "    slurm task " << r.at("slurm_task").get<std::string>() << ": " << r.at("slurm_log").get<std::string>() << "\n";
  }
  o << "total:";
  for (auto it = table.at("counts").begin(); it != table.at("counts").end(); ++it)
    o << " " << it.value().get<int>() << " " << it.key();
  o << "\n";
  return o.str();
}

void save_or_check_spec(const std::string& sweep_dir, const SweepSpec& s) {
  const fs::path p = fs::path(sweep_dir) / "spec.json";
  const nlohmann::json now = sweep_spec_json(s);
  if (fs::exists(p)) {
    const nlohmann::json before = read_json_file(p.string(), "sweep spec file");
    if (before != now)
      throw std::invalid_argument("sweep directory '" + sweep_dir + "' holds a sweep of another spec (" + p.string() +
                                  "); use a new --out, or the spec it was started with");
    return;
  }
  fs::create_directories(sweep_dir);
  write_file_atomic(p.string(), now.dump(2) + "\n");
}

SweepSpec load_sweep_spec(const std::string& sweep_dir) {
  const fs::path p = fs::path(sweep_dir) / "spec.json";
  if (!fs::exists(p))
    throw std::invalid_argument("'" + sweep_dir + "' is not a sweep directory (it has no spec.json)");
  return parse_sweep_spec(read_json_file(p.string(), "sweep spec file"));
}

}  // namespace atacom
