#include "src/experiments/sweep_local.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <deque>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <ostream>
#include <stdexcept>
#include <thread>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"
#include "src/experiments/sweep_cost.hpp"
#include "src/experiments/sweep_state.hpp"

namespace fs = std::filesystem;

namespace atacom {

namespace {

std::atomic<int> g_stop_signal{0};
extern "C" void on_stop_signal(int sig) { g_stop_signal.store(sig); }

std::string hostname() {
  char b[256] = {0};
  ::gethostname(b, sizeof(b) - 1);
  return b;
}

int env_int(const char* name) {
  const char* v = std::getenv(name);
  if (!v || !*v) return 0;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  return (end && *end == '\0' && x > 0 && x < 1 << 20) ? int(x) : 0;
}

struct Child {
  size_t cell;
  pid_t pid;
  int lock_fd;
  int attempts;
};

std::string duration(double s) {
  if (!(s >= 0) || s > 1e9) return "?";
  char b[32];
  const long t = long(s + 0.5);
  if (t >= 3600) std::snprintf(b, sizeof(b), "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(b, sizeof(b), "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(b, sizeof(b), "%lds", t);
  return b;
}

// The dry run's last lines: estimated run time of the cells still to run.
std::string sweep_cost_text(const std::vector<SweepCell>& cells, const std::vector<size_t>& to_run, int jobs,
                            int threads) {
  if (to_run.empty()) return "estimate: nothing left to run\n";
  SweepCost c;
  try {
    c = estimate_sweep_cost(cells, to_run);
  } catch (const std::exception& e) {
    return std::string("estimate: not available (") + e.what() + ")\n";
  }
  std::string out = "estimate: " + duration(c.run_seconds) + " core time";
  // jobs runs at a time; a run given more threads goes faster, at best in proportion (an upper bound here).
  out += ", about " + duration(c.run_seconds / double(std::max(1, jobs))) + " with " + std::to_string(jobs) +
         " at a time" + (threads > 1 ? " (" + std::to_string(threads) + " threads each: likely less)" : "");
  if (c.unknown > 0) out += "; " + std::to_string(c.unknown) + " runs of an env/layer without a measured rate not counted";
  return out + "\n  rates: " + c.source + " (data/sweep_rates.json; evaluations counted as full-length episodes)\n";
}

}  // namespace

int available_cores() {
  if (const int n = env_int("SLURM_CPUS_PER_TASK")) return n;
  if (const int n = env_int("SLURM_CPUS_ON_NODE")) return n;
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(1, CPU_COUNT(&set));
  return std::max(1u, std::thread::hardware_concurrency());
}

int default_sweep_jobs() { return available_cores(); }

int run_sweep_local(const SweepSpec& spec, const SweepLocalOptions& opts) {
  const std::string& dir = opts.dir;
  const std::vector<SweepCell> cells = sweep_cells(spec);
  std::vector<size_t> mine;
  if (!opts.cells.empty()) {
    std::vector<bool> listed(cells.size(), false);
    for (size_t k : opts.cells)
      if (k < cells.size()) listed[k] = true;
    for (size_t k = 0; k < cells.size(); ++k)
      if (listed[k]) mine.push_back(k);
  } else {
    for (size_t k = 0; k < cells.size(); ++k)
      if (opts.shard.holds(k)) mine.push_back(k);
  }
  const int jobs = opts.jobs > 0 ? opts.jobs : default_sweep_jobs();
  const int busy = std::max(1, std::min<int>(jobs, int(mine.size())));
  const int threads = opts.threads_per_run > 0 ? opts.threads_per_run : std::max(1, available_cores() / busy);
  auto command = [&](const SweepCell& c, bool resume) {
    std::vector<std::string> a = {opts.exe, "--threads", std::to_string(threads), "train"};
    if (resume) a.insert(a.end(), {"--out", (fs::path(dir) / c.run_dir()).string(), "--resume"});
    else a.insert(a.end(), {"--config", (fs::path(dir) / "inputs" / (c.name() + ".json")).string(), "--out",
                            (fs::path(dir) / c.run_dir()).string()});
    return a;
  };
  if (opts.dry_run) {
    if (opts.log) {
      // Without a directory there is no state to read and nothing will be
      // written: cells and the estimate only, no paths.
      *opts.log << "sweep: " << mine.size() << " runs";
      if (opts.shard.count > 1) *opts.log << " (shard " << opts.shard.index << "/" << opts.shard.count << " of " << cells.size() << ")";
      *opts.log << ", " << jobs << " at a time, " << threads << " threads each\n";
      std::error_code ec;
      const std::string self = fs::read_symlink("/proc/self/exe", ec).string();  // the binary it names
      std::vector<size_t> to_run;  // the cells to run, for the estimate
      for (size_t k : mine) {  // streamed: one line in memory at a time
        const std::string st = dir.empty() ? "fresh" : run_files_state(dir, cells[k]);
        *opts.log << cells[k].name() << "  " << (st == "fresh" ? "to run" : st == "partial" ? "to resume" : "done");
        if (st != "done") {
          to_run.push_back(k);
          if (!dir.empty()) {
            *opts.log << "  ";
            std::vector<std::string> cmd = command(cells[k], st == "partial");
            if (cmd[0] == "/proc/self/exe") cmd[0] = self;
            for (const auto& s : cmd) *opts.log << " " << s;
          }
        }
        *opts.log << "\n";
      }
      *opts.log << sweep_cost_text(cells, to_run, busy, threads);
    }
    return 0;
  }
  // A received directory is data: links in place of its parts are refused before anything is written.
  prepare_sweep_dirs(dir);
  save_or_check_spec(dir, spec);
  for (size_t k : mine) {  // inputs first: each cell re-runnable by hand from the start
    const std::string rel = "inputs/" + cells[k].name() + ".json";
    require_no_links(dir, rel, "sweep directory");
    struct stat st;
    if (::lstat((fs::path(dir) / rel).c_str(), &st) != 0)
      write_file_atomic((fs::path(dir) / rel).string(), cells[k].config().dump(2) + "\n");
  }

  g_stop_signal.store(0);
  struct sigaction sa{}, old_int{}, old_term{}, old_usr1{};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  sigaction(SIGUSR1, &sa, &old_usr1);

  // One scan of every cell's files at the start; after it each event (a run
  // started or ended) updates its own cell only: O(1) per event, whatever
  // the number of cells. sweep.json is rebuilt from this table every few
  // seconds (at most a tenth of the time) and from the files at the end.
  std::vector<CellStatus> table = cell_statuses(dir, cells);
  std::deque<size_t> queue;
  std::vector<int64_t> steps_of(cells.size(), 0);  // env steps of each of my cells as last seen
  int64_t all_steps = 0, steps_seen = 0;
  for (size_t k : mine) {
    const bool done = table[k].state == "done";
    if (!done) queue.push_back(k);
    if (!cells[k].learns) continue;
    all_steps += cells[k].steps;
    steps_of[k] = done ? cells[k].steps : table[k].env_steps;
    steps_seen += steps_of[k];
  }
  std::vector<Child> running;
  int failed = 0, done_now = 0, stopped = 0;  // stopped: interrupted by a signal to the sweep
  const pid_t me = ::getpid();
  const auto t0 = std::chrono::steady_clock::now();
  // Steps of my cells now: the last seen plus what the running ones did since (O(jobs)).
  auto steps_now = [&]() {
    int64_t s = steps_seen;
    for (const Child& ch : running)
      if (cells[ch.cell].learns) s += std::max<int64_t>(0, run_progress_steps(dir, cells[ch.cell]) - steps_of[ch.cell]);
    return s;
  };
  const int64_t steps_start = steps_seen;
  auto last_print = t0 - std::chrono::hours(1);
  auto progress = [&](bool force) {
    if (!opts.log) return;
    const auto now = std::chrono::steady_clock::now();
    const auto gap = opts.log_is_tty ? std::chrono::milliseconds(1000) : std::chrono::milliseconds(30000);
    if (!force && now - last_print < gap) return;
    last_print = now;
    const double el = std::chrono::duration<double>(now - t0).count();
    const int64_t s = steps_now();
    const double rate = el > 0 ? double(s - steps_start) / el : 0;
    const size_t left = queue.size();
    const size_t done = mine.size() - left - running.size() - size_t(failed) - size_t(stopped);
    char b[256];
    const std::string extra = (failed ? ", " + std::to_string(failed) + " failed" : std::string()) +
                              (stopped ? ", " + std::to_string(stopped) + " stopped" : std::string());
    std::snprintf(b, sizeof(b), "sweep: %zu done, %zu running, %zu left%s  %.0f env-steps/s  ETA %s", done,
                  running.size(), left, extra.c_str(), rate,
                  duration(rate > 0 ? double(all_steps - s) / rate : -1).c_str());
    if (opts.log_is_tty) *opts.log << "\r\033[K" << b << std::flush;
    else *opts.log << b << "\n" << std::flush;
  };
  // sweep.json from the table: when at least 2 s and ten times its last cost have passed.
  auto last_table = t0;
  double table_cost_s = 0;
  bool table_stale = true;
  auto write_table = [&](bool force) {
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_table).count();
    if (!table_stale || (!force && since < std::max(2.0, 10 * table_cost_s))) return;
    write_sweep_json(dir, cells, table);
    last_table = std::chrono::steady_clock::now();
    table_cost_s = std::chrono::duration<double>(last_table - now).count();
    table_stale = false;
  };

  enum class Launch { Started, Done, Held };
  auto launch = [&](size_t k) -> Launch {
    const SweepCell& c = cells[k];
    std::string why;
    const int fd = open_below(dir, cell_state_rel(c, ".lock"), O_RDWR | O_CREAT, &why);
    if (fd < 0) throw std::runtime_error("cannot open lock file '" + cell_state_path(dir, c, ".lock") + "': it " + why);
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {  // another process runs it (or a run of a killed sweep is dying)
      ::close(fd);
      return Launch::Held;
    }
    const std::string st = run_files_state(dir, c);  // again, under the lock
    if (st == "done") {
      ::close(fd);
      table[k].state = "done";
      table[k].env_steps = c.learns ? c.steps : 0;
      if (c.learns) {
        steps_seen += c.steps - steps_of[k];
        steps_of[k] = c.steps;
      }
      return Launch::Done;
    }
    // Nothing below the sweep directory is followed: a planted link in the
    // run's path is refused before anything is removed or created there.
    require_no_links(dir, c.run_dir(), "sweep directory");
    const fs::path run = fs::path(dir) / c.run_dir();
    if (st == "fresh" && fs::symlink_status(run).type() != fs::file_type::not_found)
      fs::remove_all(run);  // nothing to resume: start clean (remove_all unlinks links, never follows them)
    if (st == "partial")  // `train --resume` reads these files: regular ones only (never a link, a FIFO, a device)
      for (const fs::directory_entry& e : fs::directory_iterator(run)) {
        const fs::file_type t = e.symlink_status().type();
        const std::string name = e.path().filename().string();
        if (t != fs::file_type::regular && t != fs::file_type::directory && name.find(".tmp.") == std::string::npos)
          throw std::invalid_argument("sweep directory '" + dir + "': '" + c.run_dir() + "/" + printable_text(name) +
                                      "' is not a regular file (a symbolic link, FIFO or device); a run directory holds "
                                      "regular files only: remove it (docs/security.md)");
      }
    fs::create_directories(run.parent_path());
    const std::vector<std::string> args = command(c, st == "partial");
    const int attempts = std::min(read_cell_record(dir, c).attempts, kMaxAttempts - 1) + 1;
    const std::string log = (fs::path(dir) / cell_log_path(c)).string();
    const int log_fd = open_below(dir, cell_log_path(c), O_WRONLY | O_CREAT | O_APPEND, &why);
    if (log_fd < 0) {
      ::close(fd);
      throw std::runtime_error("cannot open log file '" + log + "': it " + why);
    }
    std::string head = "=== attempt " + std::to_string(attempts) + " on " + hostname() + " at " + utc_now() + ":";
    for (const auto& s : args) head += " " + s;
    head += "\n";
    if (::write(log_fd, head.data(), head.size()) < 0) { /* the log is best effort */ }
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
    if (pid == 0) {
      // The run dies with the sweep (kill -9 included): no orphan keeps writing a cell the next sweep resumes.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != me) ::_exit(137);
      // The run holds the cell's lock too, until it is really gone.
      ::fcntl(fd, F_SETFD, 0);
      ::dup2(log_fd, STDOUT_FILENO);
      ::dup2(log_fd, STDERR_FILENO);
      std::vector<char*> argv;
      for (const auto& s : args) argv.push_back(const_cast<char*>(s.c_str()));
      argv.push_back(nullptr);
      ::execv(args[0].c_str(), argv.data());
      std::fprintf(stderr, "sweep: cannot execute %s: %s\n", args[0].c_str(), std::strerror(errno));
      ::_exit(127);
    }
    ::close(log_fd);
    write_cell_state(dir, c, {{"state", "running"}, {"attempts", attempts}, {"host", hostname()}, {"pid", pid},
                              {"resumed", st == "partial"}, {"started_utc", utc_now()}});
    table[k].state = "running";
    table[k].attempts = attempts;
    table[k].host = hostname();
    running.push_back({k, pid, fd, attempts});
    return Launch::Started;
  };

  auto reap = [&](bool block) {
    bool changed = false;
    for (size_t i = 0; i < running.size();) {
      int status = 0;
      const pid_t r = ::waitpid(running[i].pid, &status, block ? 0 : WNOHANG);
      if (r == 0 || (r < 0 && errno == EINTR)) {
        ++i;
        continue;
      }
      const Child ch = running[i];
      const SweepCell& c = cells[ch.cell];
      const int code = r < 0 ? -1 : WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      nlohmann::json rec = {{"attempts", ch.attempts}, {"host", hostname()}, {"ended_utc", utc_now()}};
      CellStatus& row = table[ch.cell];
      const bool done = code == 0 && run_files_state(dir, c) == "done";
      if (done) {
        rec["state"] = "done";
        row.state = "done";
        ++done_now;
      } else if (g_stop_signal.load() != 0) {
        rec["state"] = "interrupted";
        row.state = "interrupted";
        ++stopped;
      } else {
        rec["state"] = "failed";
        rec["exit_code"] = code == 0 ? 1 : code;
        rec["log"] = cell_log_path(c);
        row.state = "failed";
        row.exit_code = code == 0 ? 1 : code;
        ++failed;
      }
      write_cell_state(dir, c, rec);
      row.env_steps = done ? (c.learns ? c.steps : 0) : run_progress_steps(dir, c);
      if (c.learns) {
        const int64_t now_steps = done ? c.steps : row.env_steps;
        steps_seen += now_steps - steps_of[ch.cell];
        steps_of[ch.cell] = now_steps;
      }
      ::close(ch.lock_fd);
      running.erase(running.begin() + long(i));
      changed = true;
    }
    return changed;
  };

  write_table(true);
  progress(true);
  while ((!queue.empty() || !running.empty()) && g_stop_signal.load() == 0) {
    bool changed = false;
    // Cells locked by another process go to the back and are retried later;
    // a bounded number of tries per round keeps a round O(1) even when
    // another sweep holds thousands of them.
    for (int tries = 0; int(running.size()) < jobs && !queue.empty() && g_stop_signal.load() == 0 && tries < 64;
         ++tries) {
      const size_t k = queue.front();
      queue.pop_front();
      const Launch l = launch(k);
      changed |= l != Launch::Held;
      if (l == Launch::Held) queue.push_back(k);
    }
    table_stale |= changed;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (reap(false)) {
      table_stale = true;
      progress(true);
    } else {
      progress(false);
    }
    write_table(false);
  }
  const int sig = g_stop_signal.load();
  // SIGUSR1 (pre-timeout): every run checkpoints and exits; SIGINT/SIGTERM: they stop (resume from the last checkpoint).
  if (sig != 0)
    for (const Child& ch : running) ::kill(ch.pid, sig == SIGUSR1 ? SIGUSR1 : SIGTERM);
  while (!running.empty()) reap(true);
  write_sweep_json(dir, cells);  // at the end, from every cell's files (other shards' cells too)
  progress(true);
  if (opts.log && opts.log_is_tty) *opts.log << "\n";
  sigaction(SIGINT, &old_int, nullptr);
  sigaction(SIGTERM, &old_term, nullptr);
  sigaction(SIGUSR1, &old_usr1, nullptr);
  if (sig != 0) {
    if (opts.log) *opts.log << "sweep: stopped by signal " << sig << "; run the same command again to go on\n";
    return sig == SIGUSR1 ? 75 : 130;
  }
  // Cells another process ran, or still runs, count as not finished here.
  int not_done = 0;
  for (size_t k : mine) not_done += table[k].state != "done" && run_files_state(dir, cells[k]) != "done";
  if (opts.log && failed > 0)
    *opts.log << "sweep: " << failed << " runs failed (see `atacom sweep status " << dir << "` for their logs)\n";
  return (failed > 0 || not_done > 0) ? 1 : 0;
}

}  // namespace atacom
