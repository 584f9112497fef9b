// atacom sweep: every (env, algo, seed) cell of a spec as an `atacom train`
// run, locally (K at a time) or as a Slurm job array; `atacom sweep status`.
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/core/config_json.hpp"
#include "src/experiments/sweep_local.hpp"
#include "src/experiments/sweep_slurm.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"

namespace atacom::cli {
namespace {

struct SweepArgs {
  std::string spec, out, shard = "0/1", status_dir;
  int jobs = 0, threads_per_run = 0;
  bool dry_run = false;
  CLI::App* status = nullptr;
  bool slurm = false;
  SlurmOptions so;
  std::string slurm_task;
  int task_offset = 0;
  bool jobs_set = false, threads_set = false, max_parallel_set = false;  // (their defaults depend on the machine)
  std::vector<CLI::Option*> slurm_opts;
};

int run_status(const std::string& dir) {
  const SweepSpec spec = load_sweep_spec(dir);
  nlohmann::json table = sweep_table(dir, sweep_cells(spec));
  add_slurm_tasks(dir, table);
  std::cout << sweep_status_text(table);
  for (const auto& r : table.at("runs"))
    if (r.at("state") != "done") return 1;
  return 0;
}

int run(const SweepArgs& a) {
  if (a.status->parsed()) return run_status(a.status_dir);
  if (a.spec.empty()) throw std::invalid_argument("atacom sweep: SPEC (a sweep spec JSON file) is required");
  if (a.out.empty() && !a.dry_run)
    throw std::invalid_argument("atacom sweep: --out DIR is required (or --dry-run to list the runs and their cost)");
  const SweepSpec spec = parse_sweep_spec(atacom::read_json_file(a.spec, "sweep spec"));
  if (!a.slurm)
    for (const CLI::Option* opt : a.slurm_opts)
      if (opt->count() > 0) throw std::invalid_argument(opt->get_name() + " applies to --slurm only");
  if (a.slurm) {
    if (a.dry_run || !a.slurm_task.empty() || a.shard != "0/1")
      throw std::invalid_argument("--slurm cannot be combined with --dry-run, --shard or --slurm-task");
    SlurmOptions so = a.so;
    std::error_code ec;
    so.exe = std::filesystem::read_symlink("/proc/self/exe", ec).string();
    const auto ids = submit_sweep_slurm(spec, a.out, so, std::cout);
    for (const auto& id : ids) std::cout << id << "\n";
    return 0;
  }
  SweepLocalOptions o;
  if (!a.slurm_task.empty()) o.cells = slurm_task_cells(a.slurm_task, a.task_offset);
  o.dir = a.out;
  o.jobs = a.jobs;
  o.threads_per_run = a.threads_per_run;
  o.shard = parse_shard(a.shard);
  o.dry_run = a.dry_run;
  o.log = a.dry_run ? &std::cout : &std::cerr;
  o.log_is_tty = !a.dry_run && ::isatty(STDERR_FILENO) != 0;
  return run_sweep_local(spec, o);
}

const RegisterCommand register_sweep{Command{
    "sweep", "run every (env, algo, seed) cell of a sweep spec as an `atacom train` run (resumable); `sweep status DIR`",
    [](CLI::App& app) -> std::function<int()> {
      auto a = std::make_shared<SweepArgs>();
      app.add_option("SPEC", a->spec, "sweep spec (JSON: envs, algos, seeds, steps, num_envs, overrides)");
      app.add_option("--out", a->out, "sweep directory (runs/, logs/, sweep.json; reuse it to resume)");
      add_number_flag(app, "--jobs", a->jobs, range::closed(1, 4096), "runs at a time (default: one per core)",
                      &a->jobs_set)
          ->default_str(std::to_string(default_sweep_jobs()));
      add_number_flag(app, "--threads-per-run", a->threads_per_run, range::closed(1, 4096),
                      "worker threads of each run (default: cores / jobs)", &a->threads_set);
      app.add_option("--shard", a->shard, "run only part i of n (cells k with k mod n = i), e.g. 0/4");
      app.add_flag("--dry-run", a->dry_run,
                   "list the runs and an estimated cost (from measured steps/s, data/sweep_rates.json) without "
                   "running or writing anything; with --out also each run's state and command");
      app.add_flag("--slurm", a->slurm, "submit the runs that are not done as Slurm job arrays (docs/sweeps.md)");
      a->slurm_opts = {
          app.add_option("--partition", a->so.partition, "Slurm partition"),
          app.add_option("--time", a->so.time, "Slurm time limit per task (e.g. 1-12:00:00)"),
          add_number_flag(app, "--cpus-per-task", a->so.cpus_per_task, range::closed(1, 4096),
                          "cores per task (its runs share them)"),
          app.add_option("--mem", a->so.mem, "Slurm memory per node (e.g. 4G)"),
          app.add_option("--account", a->so.account, "Slurm account"),
          add_number_flag(app, "--max-parallel", a->so.max_parallel, range::closed(1, 1000000),
                          "tasks running at once (--array=0-N%K; default: no limit)", &a->max_parallel_set),
          app.add_option("--sbatch-arg", a->so.sbatch_args, "extra sbatch option, one per flag (repeatable)"),
          add_number_flag(app, "--runs-per-task", a->so.runs_per_task, range::closed(1, 100000), "runs per array task"),
          add_number_flag(app, "--presignal", a->so.presignal_s, range::closed(10, 65535),
                          "seconds before the time limit for the checkpoint signal (--signal=B:USR1@S)")};
      app.add_option("--slurm-task", a->slurm_task, "(inside an array task) the tasks file of the submission")
          ->group("");
      add_number_flag(app, "--task-offset", a->task_offset, range::closed(0, int(kMaxSweepCells)),
                      "(inside an array task) first task of this array")
          ->group("");
      a->status = app.add_subcommand("status", "print the state of every run of a sweep directory");
      a->status->add_option("DIR", a->status_dir, "sweep directory")->required();
      app.require_subcommand(0, 1);
      return [a]() { return run(*a); };
    }}};

}  // namespace
}  // namespace atacom::cli
