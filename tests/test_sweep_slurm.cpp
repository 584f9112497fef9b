// atacom sweep --slurm without a cluster: the array script's lines, its USR1
// wrapper run by bash against a stand-in sweep and a stand-in scontrol, and
// the Slurm task logs `sweep status` names. The real cluster is the ctest
// label slurm (tests/slurm/sweep_on_slurm.sh).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "src/experiments/sweep_slurm.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

fs::path fresh_dir(const std::string& name) {
  const auto p = fs::temp_directory_path() / ("atacom_sweep_slurm_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

void write_exe(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  fs::permissions(p, fs::perms::owner_all | fs::perms::group_read | fs::perms::others_read);
}

// Runs `bash script` as an array task 7_0 (job 9) with `bin` first on PATH; sends
// USR1 once `started` exists when `signal` is set. Returns bash's exit code.
int run_task(const fs::path& script, const fs::path& bin, const fs::path& started, bool signal) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setenv("SLURM_ARRAY_JOB_ID", "7", 1);
    ::setenv("SLURM_ARRAY_TASK_ID", "0", 1);
    ::setenv("SLURM_JOB_ID", "9", 1);
    ::setenv("PATH", (bin.string() + ":" + std::getenv("PATH")).c_str(), 1);
    ::execlp("bash", "bash", script.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  if (signal) {
    for (int i = 0; i < 2000 && !fs::exists(started); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    REQUIRE(fs::exists(started));
    ::kill(pid, SIGUSR1);
  }
  int st = 0;
  ::waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

}  // namespace

TEST_CASE("sweep --slurm: the array script holds every option, split offsets and quoted paths", "[sweep]") {
  SlurmOptions o;
  o.partition = "gpu";
  o.time = "1-12:00:00";
  o.mem = "4G";
  o.account = "proj";
  o.cpus_per_task = 3;
  o.max_parallel = 5;
  o.presignal_s = 90;
  o.sbatch_args = {"--qos=low", "--exclude=node1"};
  o.exe = "/opt/it's here/atacom";
  const std::string s = slurm_array_script("/sw/dir", "/sw/dir/slurm/submit-x", "/sw/dir/slurm/submit-x/tasks.json", 1000, 7, o);
  for (const char* line : {"#SBATCH --array=0-6%5\n", "#SBATCH --cpus-per-task=3\n", "#SBATCH --time=1-12:00:00\n",
                           "#SBATCH --mem=4G\n", "#SBATCH --partition=gpu\n", "#SBATCH --account=proj\n",
                           "#SBATCH --signal=B:USR1@90\n", "#SBATCH --requeue\n", "#SBATCH --qos=low\n",
                           "#SBATCH --exclude=node1\n", "#SBATCH --output=/sw/dir/slurm/submit-x/task-%A_%a.log\n",
                           "#SBATCH --open-mode=append\n", " --task-offset 1000 &\n", "'/opt/it'\\''s here/atacom' sweep",
                           "scontrol requeue \"$task\""}) {
    INFO(line);
    CHECK(s.find(line) != std::string::npos);
  }
  o.max_parallel = 0;
  CHECK(slurm_array_script("/d", "/d/s", "/d/s/t.json", 0, 1, o).find("#SBATCH --array=0-0\n") != std::string::npos);
}

TEST_CASE("sweep --slurm: on USR1 the task script passes it on and requeues its own task, else not", "[sweep]") {
  const fs::path d = fresh_dir("wrapper"), bin = d / "bin";
  fs::create_directories(bin);
  // scontrol stand-in: records its arguments.
  write_exe(bin / "scontrol", "#!/bin/bash\necho \"$@\" >> " + (d / "scontrol.calls").string() + "\n");
  // sweep stand-in: exits 75 after USR1 (the runs wrote their checkpoints), else with $MODE.
  write_exe(d / "sweep", "#!/bin/bash\ntrap 'echo usr1 >> " + (d / "child.log").string() + "; exit 75' USR1\n"
                         "touch " + (d / "started").string() + "\n"
                         "if [ \"$MODE\" = wait ]; then for i in $(seq 2000); do sleep 0.01; done; fi\n"
                         "exit ${MODE_RC:-0}\n");
  SlurmOptions o;
  o.exe = (d / "sweep").string();
  write_exe(d / "task.sbatch", slurm_array_script(d.string(), d.string(), (d / "tasks.json").string(), 0, 1, o));

  ::setenv("MODE", "wait", 1);
  REQUIRE(run_task(d / "task.sbatch", bin, d / "started", true) == 0);
  CHECK(slurp(d / "child.log") == "usr1\n");
  CHECK(slurp(d / "scontrol.calls") == "requeue 7_0\n");  // the task, not job 9 nor array 7

  // Finished without a signal: no requeue, the sweep's exit code passes through.
  fs::remove(d / "scontrol.calls");
  ::setenv("MODE", "exit", 1);
  ::setenv("MODE_RC", "3", 1);
  CHECK(run_task(d / "task.sbatch", bin, d / "started", false) == 3);
  ::setenv("MODE_RC", "0", 1);
  CHECK(run_task(d / "task.sbatch", bin, d / "started", false) == 0);
  CHECK(!fs::exists(d / "scontrol.calls"));
  ::unsetenv("MODE");
  ::unsetenv("MODE_RC");
  fs::remove_all(d);
}

TEST_CASE("sweep status: a submitted run that is not done names its Slurm task log", "[sweep]") {
  const fs::path d = fresh_dir("status");
  fs::create_directories(d / "slurm" / "submit-a");
  fs::create_directories(d / "slurm" / "submit-b");
  // First submission: cells 0..3 as tasks of 2 arrays (MaxArraySize 3); the second resubmits cell 3.
  std::ofstream(d / "slurm/submit-a/tasks.json") << R"({"tasks":[[0],[1],[2],[3]]})";
  std::ofstream(d / "slurm/submit-b/tasks.json") << R"({"tasks":[[3]]})";
  json jobs = json::array();
  jobs.push_back({{"job_id", "11"}, {"tasks_file", (d / "slurm/submit-a/tasks.json").string()}, {"offset", 0}, {"tasks", 3}});
  jobs.push_back({{"job_id", "12"}, {"tasks_file", (d / "slurm/submit-a/tasks.json").string()}, {"offset", 3}, {"tasks", 1}});
  std::ofstream(d / "slurm/jobs.json") << jobs.dump();
  json table = {{"runs", json::array()}};
  for (const char* st : {"done", "failed", "pending", "partial"}) table["runs"].push_back({{"state", st}});
  add_slurm_tasks(d.string(), table);
  CHECK(!table["runs"][0].contains("slurm_log"));  // done: nothing to look at
  CHECK(table["runs"][1]["slurm_task"] == "11_1");
  CHECK(table["runs"][1]["slurm_log"] == "slurm/submit-a/task-11_1.log");
  CHECK(table["runs"][2]["slurm_task"] == "11_2");
  CHECK(table["runs"][3]["slurm_task"] == "12_0");
  CHECK(table["runs"][3]["slurm_log"] == "slurm/submit-a/task-12_0.log");
  jobs.push_back({{"job_id", "13"}, {"tasks_file", (d / "slurm/submit-b/tasks.json").string()}, {"offset", 0}, {"tasks", 1}});
  std::ofstream(d / "slurm/jobs.json") << jobs.dump();
  add_slurm_tasks(d.string(), table);
  CHECK(table["runs"][3]["slurm_task"] == "13_0");  // the latest submission holding the cell
  CHECK(table["runs"][3]["slurm_log"] == "slurm/submit-b/task-13_0.log");
  fs::remove_all(d);
}

TEST_CASE("sweep --slurm: --time in every Slurm form, and one too short for the signal is refused", "[sweep]") {
  CHECK(slurm_time_seconds("90") == 5400);
  CHECK(slurm_time_seconds("10:30") == 630);
  CHECK(slurm_time_seconds("1:02:03") == 3723);
  CHECK(slurm_time_seconds("1-12") == 129600);
  CHECK(slurm_time_seconds("1-12:00") == 129600);
  CHECK(slurm_time_seconds("1-12:00:00") == 129600);
  CHECK(slurm_time_seconds("2-0:0:5") == 172805);
  CHECK(slurm_time_seconds("UNLIMITED") == -1);
  for (const char* bad : {"", "1h", "1-", "-1", "1:2:3:4", "1-2-3", "1::2", "12 ", "1-2:3:4:5"}) {
    INFO(bad);
    CHECK_THROWS_WITH(slurm_time_seconds(bad), Catch::Contains("is not a Slurm time limit"));
  }
  SlurmOptions o;
  o.time = "2";  // 120 s against the default 120 s signal
  std::ostringstream log;
  CHECK_THROWS_WITH(submit_sweep_slurm(SweepSpec{}, "/nonexistent/never-written", o, log),
                    Catch::Contains("--time 2 (120 s) is too short for --presignal 120"));
  CHECK(!fs::exists("/nonexistent/never-written"));
}
