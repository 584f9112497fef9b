// atacom sweep: the spec's strictness, the cells, and the promise that a
// sweep killed at any moment (kill -9) and rerun ends with the run files of
// an uninterrupted one.
#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "run_dir_compare.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

json small_spec() {
  return json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac", "la"], "seeds": [0, 1], "steps": 2000,
    "num_envs": 4, "overrides": {"*/*": {"train": {"eval_every": 500, "eval_episodes": 2}},
                                 "table/sac": {"sac": {"lr_actor": 1e-5}}}})");
}

std::string error_of(const json& spec) {
  try {
    parse_sweep_spec(spec);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Every file of every run directory but checkpoint.bin, wall times taken out (tests/run_dir_compare.hpp).
std::map<std::string, std::string> run_files(const std::string& dir) {
  return run_dir_compare::files((fs::path(dir) / "runs").string(), dir);
}

// summary.json's modification time of every finished run: a rerun must not touch them.
std::map<std::string, fs::file_time_type> finished(const std::string& dir) {
  std::map<std::string, fs::file_time_type> out;
  if (!fs::exists(fs::path(dir) / "runs")) return out;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(dir) / "runs"))
    if (e.path().filename() == "summary.json") out[e.path().string()] = fs::last_write_time(e.path());
  return out;
}

// kill_at_write > 0: every `atacom train` the command starts kills itself
// (SIGKILL) at its kill_at_write-th file write (src/core/fs_util.hpp).
pid_t start(const std::vector<std::string>& args, const std::string& log, int kill_at_write = 0) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (kill_at_write > 0) ::setenv("ATACOM_TEST_KILL_AT_WRITE", std::to_string(kill_at_write).c_str(), 1);
    std::freopen(log.c_str(), "a", stderr);
    std::freopen(log.c_str(), "a", stdout);
    std::vector<char*> argv;
    for (const auto& s : args) argv.push_back(const_cast<char*>(s.c_str()));
    argv.push_back(nullptr);
    ::execv(args[0].c_str(), argv.data());
    ::_exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int st = 0;
  ::waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

}  // namespace

TEST_CASE("sweep: the spec is strict and names what is wrong", "[sweep]") {
  REQUIRE(error_of(small_spec()).empty());
  json j = small_spec();
  j["sedes"] = 1;
  REQUIRE(error_of(j).find("sweep.sedes") != std::string::npos);
  j = small_spec();
  j["algos"] = {"sac", "atacom-sacc"};
  REQUIRE(error_of(j).find("atacom-sacc") != std::string::npos);
  j = small_spec();
  j["seeds"] = {1, 1};
  REQUIRE(error_of(j).find("twice") != std::string::npos);
  j = small_spec();
  j["seeds"] = {-1};
  REQUIRE(error_of(j).find("seeds[0]") != std::string::npos);
  j = small_spec();
  j["steps"] = 0;
  REQUIRE(error_of(j).find("sweep.steps") != std::string::npos);
  j = small_spec();
  j["overrides"]["nav/sac"] = json::object();
  REQUIRE(error_of(j).find("env 'nav' is not in 'envs'") != std::string::npos);
  j = small_spec();
  j["overrides"]["*/sac"] = {{"train", {{"seed", 3}}}};
  REQUIRE(error_of(j).find("train.seed is set by the sweep spec") != std::string::npos);
  j = small_spec();
  j["overrides"]["table/la"] = {{"sac", {{"lr_actor", 1e-5}}}};  // la has no learner: resolved per cell
  REQUIRE(error_of(j).find("sweep cell table-la-seed0") != std::string::npos);
  j = small_spec();
  j["overrides"]["table/sac"] = {{"sac", {{"lr_actr", 1e-5}}}};
  REQUIRE(error_of(j).find("lr_actr") != std::string::npos);
  REQUIRE_THROWS_WITH(parse_shard("2/2"), Catch::Contains("0 <= i < n"));
  REQUIRE_THROWS_WITH(parse_shard("1/"), Catch::Contains("--shard"));
  REQUIRE_THROWS_WITH(parse_shard("a/3"), Catch::Contains("--shard"));
  REQUIRE(parse_shard("1/3").index == 1);
}

TEST_CASE("sweep: cells in spec order, overrides least specific first", "[sweep]") {
  json j = small_spec();
  j["overrides"]["table/*"] = {{"sac", {{"lr_actor", 2e-5}, {"lr_critic", 3e-5}}}};
  const std::vector<SweepCell> cells = sweep_cells(parse_sweep_spec(j));
  REQUIRE(cells.size() == 6);
  REQUIRE(cells[0].name() == "table-sac-seed0");
  REQUIRE(cells[0].run_dir() == "runs/table/sac/seed-0");
  REQUIRE(cells[3].name() == "table-atacom-sac-seed1");
  REQUIRE(cells[0].config()["sac"]["lr_actor"] == 1e-5);   // table/sac wins over table/*
  REQUIRE(cells[0].config()["sac"]["lr_critic"] == 3e-5);  // merged, not replaced
  REQUIRE(cells[2].config()["sac"]["lr_actor"] == 2e-5);
  REQUIRE(cells[2].config()["train"]["eval_every"] == 500);
  REQUIRE(cells[3].config()["train"]["seed"] == 1);
  REQUIRE(!cells[4].learns);
  Shard s{1, 4};
  REQUIRE((!s.holds(0) && s.holds(1) && s.holds(5) && !s.holds(6)));
}

// The scan by directory listings (cell_statuses) must find what probing every
// cell finds (cell_status): done, partial, failed, interrupted, running (a
// held lock) and a link in place of an algo's directory, among untouched cells.
TEST_CASE("sweep: the listing scan of all cells equals cell_status of each", "[sweep]") {
  json j = small_spec();
  j["seeds"] = json::array();
  for (int s = 0; s < 12; ++s) j["seeds"].push_back(s);
  const std::vector<SweepCell> cells = sweep_cells(parse_sweep_spec(j));
  const std::string dir = tmp_dir("scan_listing"), elsewhere = tmp_dir("scan_listing_elsewhere");
  prepare_sweep_dirs(dir);
  auto put = [](const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
  };
  auto cell = [&](const std::string& algo, int seed) {
    for (const SweepCell& c : cells)
      if (c.algo == algo && c.seed == seed) return c;
    FAIL("no cell " << algo << " " << seed);
    return cells[0];
  };
  const fs::path d(dir);
  put(d / cell("sac", 0).run_dir() / "summary.json", R"({"env_steps": 2000})");
  put(d / cell("sac", 1).run_dir() / "summary.json", R"({"env_steps": 1000})");
  put(d / cell("sac", 1).run_dir() / "progress.csv", "env_steps,x\n500,1\n1000,2\n");
  put(d / cell("atacom-sac", 2).run_dir() / "checkpoint.bin", "x");
  put(d / cell("atacom-sac", 2).run_dir() / "config.json", "{}");
  put(d / cell_state_rel(cell("atacom-sac", 3), ".json"), R"({"state": "failed", "attempts": 2, "exit_code": 3})");
  put(d / cell_state_rel(cell("atacom-sac", 4), ".json"), R"({"state": "running", "attempts": 1, "host": "h"})");
  put(d / cell_state_rel(cell("sac", 5), ".lock"), "");
  // Another process holds the lock: a child takes it, says so on one pipe,
  // and keeps it until the other pipe closes.
  int locked[2], go[2];
  REQUIRE((::pipe(locked) == 0 && ::pipe(go) == 0));
  const pid_t kid = ::fork();
  if (kid == 0) {
    ::close(go[1]);
    ::close(locked[0]);
    const int fd = ::open((d / cell_state_rel(cell("sac", 5), ".lock")).c_str(), O_RDWR);
    const char ok = fd >= 0 && ::flock(fd, LOCK_EX) == 0 ? 'y' : 'n';
    (void)::write(locked[1], &ok, 1);
    char b;
    (void)::read(go[0], &b, 1);
    ::_exit(0);
  }
  ::close(go[0]);
  ::close(locked[1]);
  char ok = 0;
  REQUIRE(::read(locked[0], &ok, 1) == 1);
  REQUIRE(ok == 'y');
  ::close(locked[0]);
  put(fs::path(elsewhere) / "seed-6" / "summary.json", R"({"env_steps": 2000})");
  fs::create_directories(d / "runs" / "table");
  fs::create_directory_symlink(elsewhere, d / "runs" / "table" / "la");

  const std::vector<CellStatus> listed = cell_statuses(dir, cells);
  REQUIRE(listed.size() == cells.size());
  std::map<std::string, int> counts;
  for (size_t k = 0; k < cells.size(); ++k) {
    INFO(cells[k].name());
    CHECK(sweep_row(cells[k], listed[k]).dump() == sweep_row(cells[k], cell_status(dir, cells[k])).dump());
    ++counts[listed[k].state];
  }
  ::close(go[1]);
  ::waitpid(kid, nullptr, 0);
  CHECK(counts["done"] == 1);  // sac 0; not la 6, whose summary is behind a link
  CHECK(counts["partial"] == 1);
  CHECK(counts["failed"] == 1);
  CHECK(counts["interrupted"] == 1);
  CHECK(counts["running"] == 1);
  fs::remove_all(dir);
  fs::remove_all(elsewhere);
}

// Kill moments, deterministic: in pass n every run the sweep starts (fresh or
// resumed) is killed at its n-th file write, with its temp file written and
// not renamed, which leaves the files of a kill anywhere after write n - 1;
// a run makes about 20 writes (config, progress rows and SVG, best policy,
// checkpoint and manifest per evaluation, final policy, summary), a resumed
// one 3 before its first step; passes go on until one finishes every run.
// Every third pass is followed by a kill of the whole sweep (the sweep and
// all its runs at once) at a wall-clock delay.
TEST_CASE("sweep: killed with SIGKILL at any moment, a rerun ends with the files of an uninterrupted sweep",
          "[sweep]") {
  const std::string exe = ATACOM_ATACOM_EXE;
  const std::string ref = tmp_dir("ref"), cut = tmp_dir("cut"), spec = tmp_dir("spec.json"), log = tmp_dir("log");
  json kill_spec = small_spec();  // one seed: 3 runs (a learner, one through ATACOM, one that does not learn), 2 at a time
  kill_spec["seeds"] = {0};
  std::ofstream(spec) << kill_spec.dump();
  auto sweep = [&](const std::string& dir) {
    return std::vector<std::string>{exe, "sweep", spec, "--out", dir, "--jobs", "2", "--threads-per-run", "1"};
  };
  REQUIRE(wait_exit(start(sweep(ref), log)) == 0);
  const auto want = run_files(ref);
  REQUIRE(want.size() >= 3 * 4);
  auto rerun_keeps_finished = [&](int code_wanted, auto&& run) {
    const auto before = finished(cut);
    const int code = run();
    if (code_wanted >= 0) REQUIRE(code == code_wanted);
    for (const auto& [p, t] : before) {
      INFO("finished run rewritten: " << p);
      REQUIRE(fs::last_write_time(p) == t);
    }
  };
  int passes = 0, killed = 0;
  for (int n = 1; n <= 40; ++n) {
    int code = 0;
    rerun_keeps_finished(-1, [&] { return code = wait_exit(start(sweep(cut), log, n)); });
    ++passes;
    if (code == 0) break;  // every run done: n was past their writes
    if (n % 3 == 0)        // and now and then the whole sweep at once
      rerun_keeps_finished(-1, [&] {
        const pid_t pid = start(sweep(cut), log);
        std::this_thread::sleep_for(std::chrono::milliseconds(20 * n));
        killed += ::kill(pid, SIGKILL) == 0;
        return wait_exit(pid);
      });
  }
  CHECK(passes >= 6);
  CHECK(killed >= 2);
  // The rerun waits for runs of the killed sweeps that are still dying (their cell locks).
  rerun_keeps_finished(0, [&] { return wait_exit(start(sweep(cut), log)); });
  run_dir_compare::require_same(want, run_files(cut));
  const json table = sweep_table(cut, sweep_cells(parse_sweep_spec(kill_spec)));
  REQUIRE(table["counts"]["done"] == 3);
  // A rerun of a finished sweep runs nothing; another spec in the same directory is refused.
  const auto before = fs::last_write_time(fs::path(cut) / "runs/table/sac/seed-0/summary.json");
  REQUIRE(wait_exit(start(sweep(cut), log)) == 0);
  REQUIRE(fs::last_write_time(fs::path(cut) / "runs/table/sac/seed-0/summary.json") == before);
  json other = kill_spec;
  other["steps"] = 3000;
  std::ofstream(spec) << other.dump();
  REQUIRE(wait_exit(start(sweep(cut), log)) != 0);
  REQUIRE(slurp(log).find("another spec") != std::string::npos);
  // status: exit 0 when all done
  REQUIRE(wait_exit(start({exe, "sweep", "status", cut}, log)) == 0);
  for (const auto& d : {ref, cut, spec, log}) fs::remove_all(d);
}
