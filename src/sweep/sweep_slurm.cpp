#include "src/sweep/sweep_slurm.hpp"

#include <sys/stat.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <ostream>
#include <stdexcept>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"
#include "src/sweep/sweep_state.hpp"

namespace fs = std::filesystem;

namespace atacom {

namespace {

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a shell command; returns its exit code and stdout.
int capture(const std::string& cmd, std::string& out) {
  out.clear();
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char b[4096];
  size_t n;
  while ((n = std::fread(b, 1, sizeof(b), p)) > 0) out.append(b, n);
  const int st = ::pclose(p);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

int max_array_size() {
  std::string out;
  if (capture("scontrol show config", out) == 0) {
    const size_t at = out.find("MaxArraySize");
    if (at != std::string::npos) {
      const size_t eq = out.find('=', at);
      if (eq != std::string::npos) {
        const long v = std::strtol(out.c_str() + eq + 1, nullptr, 10);
        if (v > 0) return int(v);
      }
    }
  }
  return 1001;  // Slurm's default
}

}  // namespace

std::string slurm_array_script(const std::string& dir, const std::string& sub_dir, const std::string& tasks_file,
                               int offset, int tasks, const SlurmOptions& o) {
  std::string s = "#!/bin/bash\n#SBATCH --job-name=atacom-sweep\n";
  s += "#SBATCH --array=0-" + std::to_string(tasks - 1) + (o.max_parallel > 0 ? "%" + std::to_string(o.max_parallel) : "") + "\n";
  s += "#SBATCH --cpus-per-task=" + std::to_string(o.cpus_per_task) + "\n";
  if (!o.time.empty()) s += "#SBATCH --time=" + o.time + "\n";
  if (!o.mem.empty()) s += "#SBATCH --mem=" + o.mem + "\n";
  if (!o.partition.empty()) s += "#SBATCH --partition=" + o.partition + "\n";
  if (!o.account.empty()) s += "#SBATCH --account=" + o.account + "\n";
  s += "#SBATCH --output=" + sub_dir + "/task-%A_%a.log\n#SBATCH --open-mode=append\n";
  s += "#SBATCH --signal=B:USR1@" + std::to_string(o.presignal_s) + "\n#SBATCH --requeue\n";
  for (const auto& a : o.sbatch_args) s += "#SBATCH " + a + "\n";
  s += "# Written by atacom sweep --slurm. The sweep runs in the background so that bash runs the\n"
       "# USR1 trap at once: every run writes a checkpoint and exits, then the task requeues itself\n"
       "# (named as ARRAYJOB_TASK: the task, never the whole array).\n"
       "set -u\n"
       "task=\"${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}\"\n"
       "echo \"=== task $task (job $SLURM_JOB_ID, restart ${SLURM_RESTART_COUNT:-0}) on $(hostname) at $(date -u +%FT%TZ)\"\n";
  // The trap is set before the sweep starts: a signal that comes during the start is passed on after it.
  s += "child=\nrequeue=0\n"
       "trap 'requeue=1; echo \"=== USR1 at $(date -u +%FT%T.%3NZ)\"; [ -n \"$child\" ] && kill -USR1 $child 2>/dev/null' USR1\n";
  s += quote(o.exe) + " sweep " + quote(dir + "/spec.json") + " --out " + quote(dir) + " --slurm-task " +
       quote(tasks_file) + " --task-offset " + std::to_string(offset) + " &\n";
  // rc 0: every run of the task is done, nothing to requeue (the signal came too late to matter).
  s += "child=$!\n[ $requeue = 1 ] && kill -USR1 $child 2>/dev/null\n"
       "wait $child; rc=$?\n"
       "while kill -0 $child 2>/dev/null; do wait $child; rc=$?; done\n"
       "if [ $requeue = 1 ] && [ $rc != 0 ]; then\n"
       "  echo \"=== USR1: runs checkpointed (exit $rc); requeueing $task at $(date -u +%FT%T.%3NZ)\"\n"
       "  scontrol requeue \"$task\" || { echo \"=== scontrol requeue $task failed\"; exit 75; }\n"
       "  exit 0\nfi\nexit $rc\n";
  return s;
}

namespace {

// DIR/slurm/jobs.json: a list of {job_id (digits), tasks_file, offset, tasks}; std::invalid_argument naming the file otherwise.
nlohmann::json read_jobs_file(const std::string& dir) {
  struct stat st;
  if (::lstat((fs::path(dir) / "slurm" / "jobs.json").c_str(), &st) != 0) return nlohmann::json::array();
  const nlohmann::json jobs = read_json_below(dir, "slurm/jobs.json", "slurm jobs file");
  const std::string name = "slurm jobs file '" + printable_text(dir) + "/slurm/jobs.json'";
  if (!jobs.is_array()) throw std::invalid_argument(name + " must hold a list of jobs");
  for (size_t i = 0; i < jobs.size(); ++i) {
    const nlohmann::json& j = jobs[i];
    const std::string at = name + ", job " + std::to_string(i);
    if (!j.is_object() || !j.contains("job_id") || !j["job_id"].is_string() || !j.contains("tasks_file") ||
        !j["tasks_file"].is_string())
      throw std::invalid_argument(at + ": must be an object with the strings job_id and tasks_file");
    const std::string id = j["job_id"].get<std::string>();
    if (id.empty() || id.size() > 20 || id.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument(at + ": job_id '" + printable_text(id, 40) + "' is not a Slurm job id");
    checked_number<int>(j.value("offset", nlohmann::json()), at + ": offset", range::closed<int>(0, int(kMaxSweepCells)));
    checked_number<int>(j.value("tasks", nlohmann::json()), at + ": tasks", range::closed<int>(1, int(kMaxSweepCells)));
  }
  return jobs;
}

// The "tasks" list of a submission's tasks.json (cell indices per task), read
// below DIR: slurm/<submission>/tasks.json (a moved sweep directory still
// finds its own); nullopt when it is gone.
std::optional<nlohmann::json> read_tasks_below(const std::string& dir, const std::string& tasks_file) {
  const fs::path tf(tasks_file);
  const std::string sub = tf.parent_path().filename().string();
  if (tf.filename() != "tasks.json" || sub.rfind("submit-", 0) != 0) return std::nullopt;
  const std::string rel = "slurm/" + sub + "/tasks.json";
  struct stat st;
  if (::lstat((fs::path(dir) / rel).c_str(), &st) != 0) return std::nullopt;
  const nlohmann::json t = read_json_below(dir, rel, "slurm tasks file");
  const std::string name = "slurm tasks file '" + printable_text(dir + "/" + rel) + "'";
  if (!t.is_object() || !t.contains("tasks") || !t["tasks"].is_array())
    throw std::invalid_argument(name + " must be an object with a list 'tasks'");
  for (const auto& task : t["tasks"]) {
    if (!task.is_array()) throw std::invalid_argument(name + ": every task must be a list of cell indices");
    for (const auto& cell : task) checked_number<int64_t>(cell, name + ": a cell index", range::closed<int64_t>(0, kMaxSweepCells - 1));
  }
  return t["tasks"];
}

}  // namespace

void add_slurm_tasks(const std::string& dir, nlohmann::json& table) {
  const nlohmann::json jobs = read_jobs_file(dir);
  if (jobs.empty()) return;
  nlohmann::json& runs = table.at("runs");
  std::map<std::string, std::optional<nlohmann::json>> task_files;
  for (const auto& j : jobs) {  // in submission order: the latest submission of a cell wins
    const std::string tf = j.at("tasks_file").get<std::string>();
    if (!task_files.count(tf)) task_files[tf] = read_tasks_below(dir, tf);
    if (!task_files[tf]) continue;
    const nlohmann::json& tasks = *task_files[tf];
    const std::string id = j.at("job_id").get<std::string>();
    const int off = j.at("offset").get<int>(), n = j.at("tasks").get<int>();
    for (int i = 0; i < n && size_t(off + i) < tasks.size(); ++i)
      for (const auto& cell : tasks[size_t(off + i)]) {
        const size_t k = cell.get<size_t>();
        if (k >= runs.size()) continue;
        const std::string task = id + "_" + std::to_string(i);
        runs[k]["slurm_task"] = task;
        runs[k]["slurm_log"] = "slurm/" + fs::path(tf).parent_path().filename().string() + "/task-" + task + ".log";
      }
  }
  for (auto& r : runs)
    if (r.at("state") == "done") {
      r.erase("slurm_task");
      r.erase("slurm_log");
    }
}

std::vector<size_t> slurm_task_cells(const std::string& tasks_file, int offset) {
  const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
  if (!id || !*id) throw std::invalid_argument("--slurm-task: SLURM_ARRAY_TASK_ID is not set (run inside a Slurm array task)");
  const std::optional<int> k = parse_integer<int>(id);
  if (!k || *k < 0) throw std::invalid_argument("SLURM_ARRAY_TASK_ID '" + printable_text(id, 40) + "' is not a task index");
  const nlohmann::json t = read_json_file(tasks_file, "slurm tasks file");
  const size_t task = size_t(*k) + size_t(offset);
  if (!t.is_object() || !t.contains("tasks") || !t["tasks"].is_array() || task >= t["tasks"].size() ||
      !t["tasks"][task].is_array())
    throw std::invalid_argument("slurm tasks file '" + printable_text(tasks_file) + "' has no task " + std::to_string(task));
  std::vector<size_t> cells;
  for (const auto& cell : t["tasks"][task])
    cells.push_back(size_t(checked_number<int64_t>(cell, "slurm tasks file '" + printable_text(tasks_file) + "': a cell index",
                                                   range::closed<int64_t>(0, kMaxSweepCells - 1))));
  return cells;
}

long slurm_time_seconds(const std::string& t) {
  if (t == "UNLIMITED" || t == "INFINITE" || t == "unlimited" || t == "infinite") return -1;
  const auto bad = [&]() {
    return std::invalid_argument("--time '" + printable_text(t) +
                                 "' is not a Slurm time limit (minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS)");
  };
  std::vector<long> parts;
  long days = -1;
  size_t i = 0;
  while (true) {
    size_t j = i;
    while (j < t.size() && t[j] >= '0' && t[j] <= '9') ++j;
    if (j == i || j - i > 9) throw bad();
    parts.push_back(std::stol(t.substr(i, j - i)));
    if (j == t.size()) break;
    if (t[j] == '-' && days < 0 && parts.size() == 1) {
      days = parts[0];
      parts.clear();
    } else if (t[j] != ':') {
      throw bad();
    }
    i = j + 1;
  }
  if (parts.size() > 3) throw bad();
  long s = 0;
  if (days >= 0) {  // D-HH[:MM[:SS]]
    const long mult[3] = {3600, 60, 1};
    for (size_t k = 0; k < parts.size(); ++k) s += parts[k] * mult[k];
    return days * 86400 + s;
  }
  if (parts.size() == 1) return parts[0] * 60;                                  // minutes
  if (parts.size() == 2) return parts[0] * 60 + parts[1];                       // MM:SS
  return parts[0] * 3600 + parts[1] * 60 + parts[2];                            // HH:MM:SS
}

std::vector<std::string> submit_sweep_slurm(const SweepSpec& spec, const std::string& dir_in, const SlurmOptions& o,
                                            std::ostream& log) {
  if (!o.time.empty()) {
    const long limit = slurm_time_seconds(o.time);
    if (limit >= 0 && limit <= o.presignal_s + 60)
      throw std::invalid_argument("--time " + o.time + " (" + std::to_string(limit) + " s) is too short for --presignal " +
                                  std::to_string(o.presignal_s) + ": Slurm may send the checkpoint signal up to 60 s early, "
                                  "so a task would get no work done; give --time more than presignal + 60 s");
  }
  const std::string dir = fs::absolute(dir_in).lexically_normal().string();
  prepare_sweep_dirs(dir);
  save_or_check_spec(dir, spec);
  const fs::path slurm = fs::path(dir) / "slurm";
  fs::create_directories(slurm);
  const fs::path jobs_file = slurm / "jobs.json";
  nlohmann::json jobs = read_jobs_file(dir);
  for (const auto& j : jobs) {  // never two submissions of one sweep in the queue at once
    std::string out;
    const std::string id = j.at("job_id").get<std::string>();
    // Gone: rc 0 and nothing listed, or "Invalid job id" (past MinJobAge). Any other failure (a
    // controller that does not answer also prints nothing) must not pass for "gone".
    const int rc = capture("squeue -h -o %i -j " + quote(id), out);
    if (rc != 0 && out.find("Invalid job id") == std::string::npos)
      throw std::runtime_error("cannot tell whether job " + id + " of this sweep is still queued: squeue -j " + id +
                               " failed (exit " + std::to_string(rc) + "): " + printable_text(out));
    if (rc == 0 && out.find_first_not_of(" \n") != std::string::npos)
      throw std::runtime_error("job " + id + " of this sweep is still queued or running (squeue -j " + id +
                               "); wait for it or scancel it, then submit again");
  }
  const std::vector<SweepCell> cells = sweep_cells(spec);
  std::vector<size_t> pending;
  for (size_t k = 0; k < cells.size(); ++k)
    if (run_files_state(dir, cells[k]) != "done") pending.push_back(k);
  if (pending.empty()) {
    log << "sweep: every run of " << dir << " is done; nothing to submit\n";
    return {};
  }
  for (size_t k : pending) {
    const std::string rel = "inputs/" + cells[k].name() + ".json";
    require_no_links(dir, rel, "sweep directory");
    struct stat st;
    if (::lstat((fs::path(dir) / rel).c_str(), &st) != 0)
      write_file_atomic((fs::path(dir) / rel).string(), cells[k].config().dump(2) + "\n");
  }
  nlohmann::json tasks = nlohmann::json::array();
  for (size_t i = 0; i < pending.size(); i += size_t(o.runs_per_task)) {
    nlohmann::json t = nlohmann::json::array();
    for (size_t j = i; j < std::min(pending.size(), i + size_t(o.runs_per_task)); ++j) t.push_back(pending[j]);
    tasks.push_back(t);
  }
  const std::string stamp = utc_now();
  fs::path sub = slurm / ("submit-" + stamp);
  for (int n = 2; fs::exists(sub); ++n) sub = slurm / ("submit-" + stamp + "-" + std::to_string(n));
  fs::create_directories(sub);
  const std::string tasks_file = (sub / "tasks.json").string();
  write_file_atomic(tasks_file, nlohmann::json{{"tasks", tasks}}.dump() + "\n");
  const int chunk = max_array_size();  // indices 0 .. MaxArraySize - 1
  std::vector<std::string> ids;
  for (int off = 0; off < int(tasks.size()); off += chunk) {
    const int n = std::min<int>(chunk, int(tasks.size()) - off);
    const std::string script = (sub / ("array-" + std::to_string(off) + ".sbatch")).string();
    write_file_atomic(script, slurm_array_script(dir, sub.string(), tasks_file, off, n, o));
    std::string out;
    const int rc = capture("sbatch --parsable " + quote(script), out);
    const std::string id = out.substr(0, out.find_first_of(";\n"));
    if (rc != 0 || id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
      throw std::runtime_error("sbatch " + script + " failed (exit " + std::to_string(rc) + "): " + printable_text(out));
    ids.push_back(id);
    jobs.push_back({{"job_id", id}, {"script", script}, {"tasks_file", tasks_file}, {"offset", off}, {"tasks", n},
                    {"submitted_utc", stamp}});
    write_file_atomic(jobs_file.string(), jobs.dump(2) + "\n");
    log << "sweep: submitted job " << id << " (array 0-" << n - 1 << ", " << o.runs_per_task << " runs per task; logs "
        << sub.string() << "/task-" << id << "_<i>.log)\n";
  }
  log << "sweep: " << pending.size() << " runs in " << tasks.size() << " tasks; `atacom sweep status " << dir_in
      << "` follows them\n";
  return ids;
}

}  // namespace atacom
