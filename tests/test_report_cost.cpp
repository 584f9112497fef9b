// The safe-RL baselines through sweeps and the report (issue 32): sac-lag
// and cbf-sac cells with their own sections per cell in a sweep spec; the
// report's cost metrics (train_cost, eval_cost_mean) as tables and boxes,
// the cost-return scatter and the training-cost curves, with every
// algorithm in its fixed colour and named in the figures.
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/experiments/report.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/shell_run.hpp"
#include "train/algorithms.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;


TEST_CASE("report cost: sac-lag and cbf-sac through a sweep spec, with per-cell sections", "[report][sweep]") {
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({
      "envs": ["table", "nav"], "algos": ["sac-lag", "cbf-sac", "atacom-sac"], "seeds": [0], "steps": 1000,
      "overrides": {"*/*": {"lagrangian": {"lr": 0.01}, "cbf": {"gamma": 5}},
                    "nav/sac-lag": {"lagrangian": {"cost_limit": 2}},
                    "table/cbf-sac": {"cbf": {"gamma": 20}}}})"));
  int seen = 0;
  for (const SweepCell& c : sweep_cells(spec)) {
    INFO(c.name());
    const json cfg = c.config();
    if (c.algo == "sac-lag") {
      CHECK(cfg["lagrangian"]["lr"] == 0.01);
      CHECK(!cfg.contains("cbf"));  // the wildcard's layer section reaches only cbf cells
      if (c.env == "nav") CHECK(cfg["lagrangian"]["cost_limit"] == 2);
      ++seen;
    } else if (c.algo == "cbf-sac") {
      CHECK(cfg["cbf"]["gamma"] == (c.env == "table" ? 20 : 5));
      CHECK(!cfg.contains("lagrangian"));
      ++seen;
    } else {
      CHECK(!cfg.contains("lagrangian"));
      CHECK(!cfg.contains("cbf"));
    }
  }
  CHECK(seen == 4);
  // An exact key's section must fit its cell.
  CHECK_THROWS_WITH(parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["sac"], "seeds": [0], "steps": 10,
      "overrides": {"table/sac": {"lagrangian": {"lr": 0.01}}}})")),
                    Catch::Contains("lagrangian"));
}

TEST_CASE("report cost: cost metrics, the cost-return scatter, the training-cost curves, fixed colours", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_cost_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const std::vector<std::string> algos = {"sac", "atacom-sac", "sac-lag", "cbf-sac", "safelayer-sac", "la"};
  json sj = {{"envs", {"table"}}, {"algos", algos}, {"seeds", {0, 1, 2, 3}}, {"steps", 3000}};
  const SweepSpec spec = parse_sweep_spec(sj);
  save_or_check_spec(dir, spec);
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const size_t a = size_t(std::find(algos.begin(), algos.end(), c.algo) - algos.begin());
    const double s = double(c.seed);
    // sac pays thousands, atacom-sac nothing: the training-cost axis turns logarithmic.
    const double tc = c.learns ? (c.algo == "atacom-sac" ? 0.0 : 1000.0 * double(a + 1) + 10 * s) : 0.0;
    const json sm = {{"env_steps", c.learns ? 3000 : 0}, {"eval_return_mean", -300 + 20 * double(a) + s},
                     {"eval_discounted_return_mean", -100 + double(a)}, {"final_distance", 0.2},
                     {"train_cost", tc}, {"eval_cost_mean", c.algo == "sac" ? 12 + s : 0.5 * s},
                     {"best", {{"eval_return_mean", -290.0}, {"env_steps", 1000}}}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance,train_cost\n"
                                        << "1000,0,0.1,-400,1," << tc / 3 << "\n3000,0,0.2,-300,0.5," << tc << "\n";
  }
  ReportOptions o;
  o.dir = dir;
  o.resamples = 200;
  o.curve_resamples = 100;
  const ReportResult res = write_report(o);
  REQUIRE(res.finished == 24);
  const std::string rd = dir + "/report/";
  for (const char* f : {"cost_return_table.svg", "train_cost_table.svg", "box_table.svg", "curves_table.svg"})
    REQUIRE(fs::exists(rd + f));
  const std::string scatter = slurp(rd + "cost_return_table.svg"), tcost = slurp(rd + "train_cost_table.svg");
  const std::string box = slurp(rd + "box_table.svg"), curves = slurp(rd + "curves_table.svg");
  // Every algorithm in its own colour, the same in every figure; colours differ.
  std::set<std::string> colours;
  for (const std::string& a : algos) {
    INFO(a);
    const std::string col = algorithm_color(a);
    colours.insert(col);
    CHECK(box.find(col) != std::string::npos);
    CHECK(scatter.find(col) != std::string::npos);
    CHECK(curves.find(col) != std::string::npos);
    // named: under its box (besides the legend) and beside its IQM diamond
    CHECK(occurrences(box, ">" + a + "</text>") >= 2);
    CHECK(occurrences(scatter, ">" + a + "</text>") >= 2);
  }
  CHECK(colours.size() == algos.size());
  CHECK(algorithm_color("sac-lag") == algorithm_color("sac-lag"));
  CHECK(algorithm_color("some-new-algo").size() == 7);
  // The training-cost curves: the learners only (la does not train), a log axis (values in the thousands).
  CHECK(tcost.find("log scale") != std::string::npos);
  CHECK(occurrences(tcost, ">sac-lag</text>") >= 2);  // legend and the curve's end
  CHECK(occurrences(tcost, ">la</text>") == 1);        // the legend only
  CHECK(scatter.find("(log scale)") != std::string::npos);  // training cost 0 .. 6000
  CHECK(scatter.find("no finished run") == std::string::npos);
  CHECK(tcost.find("no finished run") == std::string::npos);
  // The cost metrics are tables, boxes and P(improvement) rows.
  const std::string csv = slurp(rd + "summary.csv");
  CHECK(csv.find("table,sac-lag,train_cost,4,") != std::string::npos);
  CHECK(csv.find("table,cbf-sac,eval_cost_mean,4,") != std::string::npos);
  const std::string pi = slurp(rd + "prob_improvement.csv");
  // atacom-sac's 0 training cost against sac-lag's thousands: it improves on every pair, in every resample (interval [1, 1]).
  CHECK(pi.find("table,train_cost,atacom-sac,sac-lag,4,4,1,1,1\n") != std::string::npos);
  CHECK(box.find("cost steps (training)") != std::string::npos);
  CHECK(slurp(rd + "index.html").find("cost_return") == std::string::npos);  // inline SVG, no file references
  CHECK(slurp(rd + "summary.md").find("cost_return_table.svg") != std::string::npos);
  fs::remove_all(dir);
}

// The names end to end: `atacom sweep` trains sac-lag and cbf-sac (and la),
// `atacom report` reads their run files into the cost figures and tables.
TEST_CASE("report cost: sac-lag and cbf-sac runs of a real sweep reach the report", "[report][sweep]") {
  const fs::path dir = fs::temp_directory_path() / ("atacom_cost_sweep_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path spec = dir / "spec.json", out = dir / "sweep";
  std::ofstream(spec) << R"({"envs": ["nav"], "algos": ["sac-lag", "cbf-sac", "la"], "seeds": [0, 1, 2], "steps": 600,
      "num_envs": 4, "overrides": {"*/*": {"train": {"eval_every": 300, "eval_episodes": 1},
                                           "sac": {"warmup": 200, "batch_size": 32}},
                                   "nav/sac-lag": {"lagrangian": {"cost_limit": 1}}}})";
  const std::string exe = ATACOM_ATACOM_EXE;
  const ShellResult sw = run_shell(exe + " sweep " + spec.string() + " --out " + out.string() +
                                   " --jobs 2 --threads-per-run 1 2>&1");
  INFO(sw.out);
  REQUIRE(sw.rc == 0);
  const json lag = json::parse(slurp((out / "runs/nav/sac-lag/seed-0/summary.json").string()));
  CHECK(lag["cost_limit"] == 1.0);
  CHECK(lag.contains("train_cost"));
  CHECK(lag.contains("eval_cost_mean"));
  const std::string progress = slurp((out / "runs/nav/sac-lag/seed-0/progress.csv").string());
  CHECK(progress.substr(0, progress.find('\n')).find("lagrange_multiplier") != std::string::npos);
  const ShellResult rep = run_shell(exe + " report " + out.string() + " 2>&1");
  INFO(rep.out);
  REQUIRE(rep.rc == 0);
  const fs::path rd = out / "report";
  REQUIRE(fs::exists(rd / "cost_return_nav.svg"));
  REQUIRE(fs::exists(rd / "train_cost_nav.svg"));
  const std::string csv = slurp((rd / "summary.csv").string());
  for (const char* row : {"nav,sac-lag,train_cost,3,", "nav,cbf-sac,train_cost,3,", "nav,sac-lag,eval_cost_mean,3,",
                          "nav,cbf-sac,eval_cost_mean,3,"})
    CHECK(csv.find(row) != std::string::npos);
  CHECK(occurrences(slurp((rd / "train_cost_nav.svg").string()), ">cbf-sac</text>") >= 2);
  fs::remove_all(dir);
}

// Runs from a build before the cost keys (the paper comparison's 2M runs):
// the cost figures say the key is missing instead of drawing empty axes.
TEST_CASE("report cost: runs without cost keys get a note, not empty axes", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_nocost_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["shelf"], "algos": ["sac", "atacom-sac"],
      "seeds": [0, 1], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const json sm = {{"env_steps", 3000}, {"eval_return_mean", -300.0 + double(c.seed)}, {"final_distance", 0.2}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance\n"
                                        << "1000,0,0.1,-400,1\n3000,0,0.2,-300,0.5\n";
  }
  ReportOptions o;
  o.dir = dir;
  o.resamples = 200;
  o.curve_resamples = 100;
  REQUIRE(write_report(o).finished == 4);
  const std::string scatter = slurp(dir + "/report/cost_return_shelf.svg");
  const std::string tcost = slurp(dir + "/report/train_cost_shelf.svg");
  CHECK(scatter.find("no finished run of shelf records eval_cost_mean") != std::string::npos);
  CHECK(scatter.find("no finished run of shelf records train_cost") != std::string::npos);
  CHECK(tcost.find("no finished run of shelf records train_cost") != std::string::npos);
  fs::remove_all(dir);
}
