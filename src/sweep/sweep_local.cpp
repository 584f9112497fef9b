#include "src/sweep/sweep_local.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <ostream>
#include <stdexcept>
#include <thread>

#include "src/core/fs_util.hpp"
#include "src/sweep/sweep_cost.hpp"
#include "src/sweep/sweep_state.hpp"

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
std::string sweep_cost_text(const std::vector<SweepCell>& todo, int jobs, int threads) {
  if (todo.empty()) return "estimate: nothing left to run\n";
  SweepCost c;
  try {
    c = estimate_sweep_cost(todo);
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
  for (size_t k = 0; k < cells.size(); ++k)
    if (opts.cells.empty() ? opts.shard.holds(k) : std::find(opts.cells.begin(), opts.cells.end(), k) != opts.cells.end())
      mine.push_back(k);
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
      std::vector<SweepCell> todo;
      for (size_t k : mine) {
        const std::string st = dir.empty() ? "fresh" : run_files_state(dir, cells[k]);
        *opts.log << cells[k].name() << "  " << (st == "fresh" ? "to run" : st == "partial" ? "to resume" : "done");
        if (st != "done") {
          todo.push_back(cells[k]);
          if (!dir.empty()) {
            *opts.log << "  ";
            std::vector<std::string> cmd = command(cells[k], st == "partial");
            std::error_code ec;
            if (cmd[0] == "/proc/self/exe") cmd[0] = fs::read_symlink(cmd[0], ec).string();  // the binary it names
            for (const auto& s : cmd) *opts.log << " " << s;
          }
        }
        *opts.log << "\n";
      }
      *opts.log << sweep_cost_text(todo, busy, threads);
    }
    return 0;
  }
  save_or_check_spec(dir, spec);
  for (const char* sub : {"inputs", "logs", "state", "runs"}) fs::create_directories(fs::path(dir) / sub);
  for (size_t k : mine) {  // inputs first: each cell re-runnable by hand from the start
    const std::string p = (fs::path(dir) / "inputs" / (cells[k].name() + ".json")).string();
    if (!fs::exists(p)) write_file_atomic(p, cells[k].config.dump(2) + "\n");
  }

  g_stop_signal.store(0);
  struct sigaction sa{}, old_int{}, old_term{}, old_usr1{};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, &old_int);
  sigaction(SIGTERM, &sa, &old_term);
  sigaction(SIGUSR1, &sa, &old_usr1);

  std::vector<size_t> queue;
  for (size_t k : mine)
    if (run_files_state(dir, cells[k]) != "done") queue.push_back(k);
  size_t next = 0;
  std::vector<Child> running;
  int failed = 0, done_now = 0, stopped = 0;  // stopped: interrupted by a signal to the sweep
  const pid_t me = ::getpid();
  const auto t0 = std::chrono::steady_clock::now();
  auto total_steps = [&]() {
    int64_t s = 0;
    for (size_t k : mine)
      if (cells[k].learns) s += cells[k].steps;
    return s;
  };
  auto steps_now = [&]() {
    int64_t s = 0;
    for (size_t k : mine) {
      if (!cells[k].learns) continue;
      s += run_files_state(dir, cells[k]) == "done" ? cells[k].steps
                                                     : run_progress_steps((fs::path(dir) / cells[k].run_dir()).string());
    }
    return s;
  };
  const int64_t all_steps = total_steps(), steps_start = steps_now();
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
    const size_t left = queue.size() - next;
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

  enum class Launch { Started, Done, Held };
  auto launch = [&](size_t k) -> Launch {
    const SweepCell& c = cells[k];
    const std::string lock = cell_state_path(dir, c, ".lock");
    const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error("cannot open lock file '" + lock + "': " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {  // another process runs it (or a run of a killed sweep is dying)
      ::close(fd);
      return Launch::Held;
    }
    const std::string st = run_files_state(dir, c);  // again, under the lock
    if (st == "done") {
      ::close(fd);
      return Launch::Done;
    }
    const fs::path run = fs::path(dir) / c.run_dir();
    if (st == "fresh" && fs::exists(run)) fs::remove_all(run);  // nothing to resume: start clean
    fs::create_directories(run.parent_path());
    const std::vector<std::string> args = command(c, st == "partial");
    nlohmann::json rec = read_cell_state(dir, c);
    const int attempts = rec.value("attempts", 0) + 1;
    const std::string log = (fs::path(dir) / cell_log_path(c)).string();
    const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log_fd < 0) throw std::runtime_error("cannot open log file '" + log + "': " + std::strerror(errno));
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
      if (code == 0 && run_files_state(dir, c) == "done") {
        rec["state"] = "done";
        ++done_now;
      } else if (g_stop_signal.load() != 0) {
        rec["state"] = "interrupted";
        ++stopped;
      } else {
        rec["state"] = "failed";
        rec["exit_code"] = code == 0 ? 1 : code;
        rec["log"] = cell_log_path(c);
        ++failed;
      }
      write_cell_state(dir, c, rec);
      ::close(ch.lock_fd);
      running.erase(running.begin() + long(i));
      changed = true;
    }
    return changed;
  };

  write_sweep_json(dir, cells);
  progress(true);
  while ((next < queue.size() || !running.empty()) && g_stop_signal.load() == 0) {
    bool changed = false;
    size_t held = 0;  // cells locked by another process: retried until it is done with them
    while (int(running.size()) < jobs && next < queue.size() && g_stop_signal.load() == 0 && held < queue.size()) {
      const Launch l = launch(queue[next]);
      changed |= l == Launch::Started;
      if (l == Launch::Held) {
        queue.push_back(queue[next]);
        ++held;
      }
      ++next;
      if (l == Launch::Held && next + held >= queue.size()) break;  // only held cells left: wait a little
    }
    if (changed) write_sweep_json(dir, cells);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (reap(false)) {
      write_sweep_json(dir, cells);
      progress(true);
    } else {
      progress(false);
    }
  }
  const int sig = g_stop_signal.load();
  // SIGUSR1 (pre-timeout): every run checkpoints and exits; SIGINT/SIGTERM: they stop (resume from the last checkpoint).
  if (sig != 0)
    for (const Child& ch : running) ::kill(ch.pid, sig == SIGUSR1 ? SIGUSR1 : SIGTERM);
  while (!running.empty()) reap(true);
  write_sweep_json(dir, cells);
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
  for (size_t k : mine) not_done += run_files_state(dir, cells[k]) != "done";
  if (opts.log && failed > 0)
    *opts.log << "sweep: " << failed << " runs failed (see `atacom sweep status " << dir << "` for their logs)\n";
  return (failed > 0 || not_done > 0) ? 1 : 0;
}

}  // namespace atacom
