#include "src/experiments/sweep_state.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <optional>
#include <unordered_set>
#include <sstream>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"

namespace fs = std::filesystem;

namespace atacom {

namespace {

// The names in directory d, or nullopt when it has more than max_entries
// (a received directory of millions of files costs no unbounded memory: the
// caller probes cell by cell instead). A missing directory lists as empty.
std::optional<std::unordered_set<std::string>> listing(const fs::path& d, size_t max_entries) {
  std::unordered_set<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(d, ec), end; !ec && it != end; it.increment(ec)) {
    if (names.size() >= max_entries) return std::nullopt;
    names.insert(it->path().filename().string());
  }
  return names;
}

}  // namespace

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char b[32];
  std::strftime(b, sizeof(b), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return b;
}

std::optional<CellRecord> parse_cell_record(std::string_view text) {
  try {
    const nlohmann::json j = parse_json_strict(text, "cell state file");
    if (!j.is_object()) return std::nullopt;
    CellRecord r;
    if (const auto s = j.find("state"); s != j.end()) {
      if (!s->is_string()) return std::nullopt;
      r.state = s->get<std::string>();
      if (r.state != "running" && r.state != "done" && r.state != "failed" && r.state != "interrupted")
        return std::nullopt;
    }
    if (j.contains("attempts"))
      r.attempts = checked_number<int>(j["attempts"], "attempts", range::closed(0, kMaxAttempts));
    if (j.contains("exit_code")) r.exit_code = checked_number<int>(j["exit_code"], "exit_code", range::closed(-1, 255));
    if (const auto h = j.find("host"); h != j.end()) {
      if (!h->is_string() || h->get_ref<const std::string&>().size() > 255) return std::nullopt;
      r.host = printable_text(h->get<std::string>());
    }
    return r;
  } catch (const std::invalid_argument&) {
    return std::nullopt;
  }
}

std::string cell_state_rel(const SweepCell& c, const char* ext) { return "state/" + c.name() + ext; }

std::string cell_state_path(const std::string& sweep_dir, const SweepCell& c, const char* ext) {
  return (fs::path(sweep_dir) / cell_state_rel(c, ext)).string();
}

std::string cell_log_path(const SweepCell& c) { return "logs/" + c.name() + ".log"; }

CellRecord read_cell_record(const std::string& sweep_dir, const SweepCell& c) {
  const std::optional<std::string> text = read_below(sweep_dir, cell_state_rel(c, ".json"), kMaxCellStateBytes);
  if (!text) return {};
  // Atomic writes make an unreadable record rare (a hand edit, a received directory); the run files still decide "done".
  return parse_cell_record(*text).value_or(CellRecord{});
}

void write_cell_state(const std::string& sweep_dir, const SweepCell& c, const nlohmann::json& state) {
  fs::create_directories(fs::path(sweep_dir) / "state");  // a sweep checked it first (prepare_sweep_dirs)
  write_file_atomic(cell_state_path(sweep_dir, c, ".json"), state.dump(2) + "\n");
}

int64_t run_progress_steps(const std::string& sweep_dir, const SweepCell& c) {
  // The last row is all this needs: the file's tail, never the whole of a large one.
  const std::optional<std::string> text =
      read_below(sweep_dir, c.run_dir() + "/progress.csv", kProgressTailBytes, nullptr, true);
  if (!text) return 0;
  size_t end = text->find_last_not_of("\r\n");
  if (end == std::string::npos) return 0;
  const size_t begin = text->rfind('\n', end);
  const std::string_view last = std::string_view(*text).substr(begin == std::string::npos ? 0 : begin + 1,
                                                               end + 1 - (begin == std::string::npos ? 0 : begin + 1));
  if (begin == std::string::npos) return 0;  // the header alone (or a tail without a row start)
  const std::optional<int64_t> v = parse_integer<int64_t>(last.substr(0, last.find(',')));
  return v && *v >= 0 ? *v : 0;
}

std::string run_files_state(const std::string& sweep_dir, const SweepCell& c) {
  const std::string run = c.run_dir();
  if (const std::optional<std::string> text = read_below(sweep_dir, run + "/summary.json", kMaxSummaryBytes)) {
    try {
      const nlohmann::json s = parse_json_strict(*text, "summary file");
      if (!c.learns) return "done";
      // A run that stopped at its quality target (train.stop_at_target) is done before its budget.
      if (s.is_object() && s.value("stopped_at_target", nlohmann::json(false)) == true) return "done";
      if (s.is_object() && s.contains("env_steps") &&
          checked_number<int64_t>(s["env_steps"], "env_steps", range::at_least<int64_t>(0)) >= c.steps)
        return "done";
    } catch (const std::invalid_argument&) {
      // unreadable: not done; the checkpoint decides
    }
  }
  if (c.learns && regular_file_below(sweep_dir, run + "/checkpoint.bin") &&
      regular_file_below(sweep_dir, run + "/config.json"))
    return "partial";
  return "fresh";
}

bool cell_locked_elsewhere(const std::string& sweep_dir, const SweepCell& c) {
  const int fd = open_below(sweep_dir, cell_state_rel(c, ".lock"), O_RDONLY, nullptr);
  if (fd < 0) return false;
  const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return held;
}

CellStatus cell_status(const std::string& sweep_dir, const SweepCell& c) {
  CellStatus st;
  const std::string files = run_files_state(sweep_dir, c);
  const CellRecord rec = read_cell_record(sweep_dir, c);
  st.attempts = rec.attempts;
  st.host = rec.host;
  st.env_steps = run_progress_steps(sweep_dir, c);
  if (files == "done") {
    st.state = "done";
    st.env_steps = c.learns ? std::max(st.env_steps, c.steps) : 0;
    return st;
  }
  if (cell_locked_elsewhere(sweep_dir, c)) st.state = "running";
  else if (rec.state == "failed") {
    st.state = "failed";
    st.exit_code = rec.exit_code;
  } else if (rec.state == "running") st.state = "interrupted";  // its process died without a word
  else st.state = files == "partial" ? "partial" : "pending";
  return st;
}

std::vector<CellStatus> cell_statuses(const std::string& sweep_dir, const std::vector<SweepCell>& cells) {
  // A cell has at most a few files in state/ and one directory per seed.
  const size_t cap = 4 * cells.size() + 1024;
  const auto state = listing(fs::path(sweep_dir) / "state", cap);
  std::map<std::pair<std::string, std::string>, std::optional<std::unordered_set<std::string>>> seed_dirs;
  std::vector<CellStatus> out;
  out.reserve(cells.size());
  for (const SweepCell& c : cells) {
    auto it = seed_dirs.find({c.env, c.algo});
    if (it == seed_dirs.end())
      it = seed_dirs.emplace(std::make_pair(c.env, c.algo), listing(fs::path(sweep_dir) / "runs" / c.env / c.algo, cap))
               .first;
    const std::string name = c.name();
    const bool may_have_files = !state || !it->second || state->count(name + ".json") || state->count(name + ".lock") ||
                                it->second->count("seed-" + std::to_string(c.seed));
    if (may_have_files) {
      out.push_back(cell_status(sweep_dir, c));
    } else {
      CellStatus pending;  // what cell_status finds without any file
      pending.state = "pending";
      out.push_back(std::move(pending));
    }
  }
  return out;
}

nlohmann::json sweep_row(const SweepCell& c, const CellStatus& st) {
  nlohmann::json r = {{"name", c.name()}, {"env", c.env}, {"algo", c.algo}, {"seed", c.seed},
                      {"dir", c.run_dir()}, {"state", st.state}, {"env_steps", st.env_steps},
                      {"steps", c.learns ? c.steps : 0}, {"log", cell_log_path(c)}, {"attempts", st.attempts}};
  if (st.state == "failed") r["exit_code"] = st.exit_code;
  if (!st.host.empty()) r["host"] = st.host;
  return r;
}

nlohmann::json sweep_table(const std::string& sweep_dir, const std::vector<SweepCell>& cells) {
  nlohmann::json runs = nlohmann::json::array();
  std::map<std::string, int> counts;
  const std::vector<CellStatus> statuses = cell_statuses(sweep_dir, cells);
  for (size_t k = 0; k < cells.size(); ++k) {
    ++counts[statuses[k].state];
    runs.push_back(sweep_row(cells[k], statuses[k]));
  }
  return {{"updated_utc", utc_now()}, {"counts", counts}, {"runs", runs}};
}

void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells,
                      const std::vector<CellStatus>& statuses) {
  std::map<std::string, int> counts;
  std::string rows;
  for (size_t k = 0; k < cells.size() && k < statuses.size(); ++k) {
    ++counts[statuses[k].state];
    rows += (k ? ",\n    " : "\n    ") + sweep_row(cells[k], statuses[k]).dump();
  }
  // The keys in the order a JSON tree of the same table prints them.
  const std::string text = "{\n  \"counts\": " + nlohmann::json(counts).dump() + ",\n  \"runs\": [" + rows +
                           (rows.empty() ? "]" : "\n  ]") + ",\n  \"updated_utc\": \"" + utc_now() + "\"\n}\n";
  write_file_atomic((fs::path(sweep_dir) / "sweep.json").string(), text);
}

void write_sweep_json(const std::string& sweep_dir, const std::vector<SweepCell>& cells) {
  write_sweep_json(sweep_dir, cells, cell_statuses(sweep_dir, cells));
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

void prepare_sweep_dirs(const std::string& sweep_dir) {
  fs::create_directories(sweep_dir);
  for (const char* sub : {"inputs", "logs", "state", "runs", "slurm", "report"}) {
    require_no_links(sweep_dir, sub, "sweep directory");
    struct stat st;
    const std::string p = (fs::path(sweep_dir) / sub).string();
    if (::lstat(p.c_str(), &st) == 0 && !S_ISDIR(st.st_mode))
      throw std::invalid_argument("sweep directory '" + sweep_dir + "': '" + sub + "' is not a directory");
    if (std::string(sub) != "slurm" && std::string(sub) != "report") fs::create_directory(p);
  }
}

void save_or_check_spec(const std::string& sweep_dir, const SweepSpec& s) {
  const fs::path p = fs::path(sweep_dir) / "spec.json";
  const nlohmann::json now = sweep_spec_json(s);
  fs::create_directories(sweep_dir);
  // Exclusive: of two sweeps starting at once on an empty directory, one
  // creates spec.json and the other compares against it.
  if (create_file_exclusive(p.string(), now.dump(2) + "\n")) return;
  const nlohmann::json before = read_json_below(sweep_dir, "spec.json", "sweep spec file");
  if (before != now)
    throw std::invalid_argument("sweep directory '" + sweep_dir + "' holds a sweep of another spec (" + p.string() +
                                "); use a new --out, or the spec it was started with");
}

SweepSpec load_sweep_spec(const std::string& sweep_dir) {
  struct stat st;
  const std::string p = (fs::path(sweep_dir) / "spec.json").string();
  if (::lstat(p.c_str(), &st) != 0)
    throw std::invalid_argument("'" + sweep_dir + "' is not a sweep directory (it has no spec.json)");
  return parse_sweep_spec(read_json_below(sweep_dir, "spec.json", "sweep spec file"));
}

}  // namespace atacom
