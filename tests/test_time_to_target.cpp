// Time to target: every env's quality target as data, the verdict on an
// evaluation (HRI-Sim's spill rule), the first evaluation that meets it in
// summary.json and progress.csv against the run's own rows, null when never,
// resume equality and --stop-at-target ending at that row.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/evaluate.hpp"
#include "atacom/trainer.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/csv_rows.hpp"
#include "tests/test_files.hpp"
#include "tests/train_run.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using ProgressCsv = csv_rows::Table;
ProgressCsv read_progress(const std::string& dir) { return csv_rows::read_table(dir + "/progress.csv"); }
// Every row without its wall-clock cells (wall_s, time_to_target_s).
std::vector<std::string> rows_without_wall(const ProgressCsv& c) {
  std::vector<std::string> out;
  for (const auto& r : c.rows) {
    std::string s;
    for (size_t k = 0; k < r.size(); ++k)
      if (c.head[k] != "wall_s" && c.head[k] != "time_to_target_s") s += r[k] + ",";
    out.push_back(s);
  }
  return out;
}
json summary_without_wall(const std::string& dir) {
  json s = json::parse(slurp(dir + "/summary.json"));
  for (const char* k : {"wall_s", "time_to_target_s", "eval_wall_s", "eval_share"}) s.erase(k);
  return s;
}

// A short SAC run on TableEnv (40-step episodes, small networks): its
// evaluations' final distances fall as the policy learns (from 0.42 m to
// 0.39 m over 12 evaluations), and it collides and violates while training.
json table_run(int64_t steps, double target) {
  return {{"env", {{"horizon", 40}, {"target_distance", target}}},
          {"sac", {{"actor", {{"hidden", {32, 32}}}}, {"critic", {{"hidden", {32, 32}}}}, {"batch_size", 32},
                   {"initial_replay", 100}, {"warmup", 100}, {"replay_capacity", 5000}}},
          {"train", {{"env", "table"}, {"algo", "sac"}, {"steps", steps}, {"num_envs", 2}, {"eval_every", 100},
                     {"eval_episodes", 2}, {"seed", 3}}}};
}

atacom::EnvSpec spec_of(const std::string& env, const json& config = json::object()) {
  return atacom::make_env(atacom::EnvRequest{env, 1, atacom::SafetyLayer::None, config})->spec();
}

}  // namespace

TEST_CASE("time to target: every env declares its rule as data, shown and overridden in its config", "[target]") {
  const atacom::EnvSpec table = spec_of("table"), shelf = spec_of("shelf"), hri = spec_of("hri"), nav = spec_of("nav"),
                        pend = spec_of("pendulum");
  CHECK(table.target.distance == 0.05);
  CHECK(table.target.zero_info.empty());
  CHECK(shelf.target.distance == 0.05);
  CHECK(shelf.target.zero_info.empty());
  CHECK(hri.target.distance == 0.15);
  CHECK(hri.target.zero_info == std::vector<std::string>{"spill"});
  CHECK(nav.target.distance == 0.5);
  CHECK(nav.target.zero_info.empty());
  CHECK(!pend.target.defined());
  // The resolved config (a run's config.json) holds the rule.
  const json h = atacom::resolve_env_config("hri", json::object());
  CHECK(h["target_distance"] == 0.15);
  CHECK(h["target_zero_info"] == json::array({"spill"}));
  CHECK(!atacom::resolve_env_config("pendulum", json::object()).contains("target_distance"));
  // A safety layer keeps the env's rule.
  CHECK(atacom::make_env(atacom::EnvRequest{"hri", 1, atacom::SafetyLayer::Atacom, json::object()})->spec().target.zero_info ==
        std::vector<std::string>{"spill"});
  // Overrides, and bad ones named.
  const atacom::EnvSpec t2 = spec_of("table", {{"target_distance", 0.2}, {"target_zero_info", {"collision"}}});
  CHECK(t2.target.distance == 0.2);
  CHECK(t2.target.zero_info == std::vector<std::string>{"collision"});
  CHECK_THROWS_WITH(spec_of("table", {{"target_zero_info", {"spill"}}}),
                    Catch::Contains("env.target_zero_info") && Catch::Contains("'spill' is not an info column"));
  CHECK_THROWS_WITH(spec_of("nav", {{"target_distance", -0.1}}), Catch::Contains("env.target_distance"));
  CHECK_THROWS_WITH(spec_of("nav", {{"target_zero_info", {"at_goal", "at_goal"}}}), Catch::Contains("twice"));
  CHECK_THROWS_WITH(spec_of("pendulum", {{"target_distance", 0.1}}), Catch::Contains("target_distance"));
}

TEST_CASE("time to target: the verdict on an evaluation (hri with a spill does not meet it)", "[target]") {
  const atacom::EnvSpec hri = spec_of("hri");
  atacom::EvalResult r;
  r.episodes = 10;
  r.info_names = hri.info_names;
  r.info.assign(hri.info_names.size(), 0.0);
  size_t spill = 0;
  while (hri.info_names[spill] != "spill") ++spill;
  r.final_distance = 0.12;
  CHECK(atacom::meets_target(hri.target, r));
  r.info[spill] = 0.1;  // one episode of ten spilled
  CHECK(!atacom::meets_target(hri.target, r));
  r.info[spill] = 0.0;
  r.final_distance = 0.15;  // the bound itself meets it
  CHECK(atacom::meets_target(hri.target, r));
  r.final_distance = 0.1500001;
  CHECK(!atacom::meets_target(hri.target, r));
  r.final_distance = std::nan("");
  CHECK(!atacom::meets_target(hri.target, r));
  // The same evaluation on TableEnv's rule: a spill column is not part of it.
  atacom::EnvTarget table{0.15, {}};
  r.final_distance = 0.1;
  r.info[spill] = 1.0;
  CHECK(atacom::meets_target(table, r));
  CHECK(!atacom::meets_target(atacom::EnvTarget{}, r));  // no target: never met
  CHECK(atacom::target_json(atacom::EnvTarget{}).is_null());
  CHECK(atacom::target_json(hri.target) == json({{"distance", 0.15}, {"zero_info", {"spill"}}}));
}

TEST_CASE("time to target: the first evaluation that meets it, null when never, resume, --stop-at-target", "[target]") {
  const int64_t steps = 1200;
  // Never met (a final distance of exactly 0): null keys, empty cells.
  const std::string never = tmp_dir("never");
  train(table_run(steps, 0.0), never);
  const json sn = json::parse(slurp(never + "/summary.json"));
  for (const char* k : {"time_to_target_s", "steps_to_target", "updates_to_target", "train_cost_to_target"}) {
    INFO(k);
    REQUIRE(sn.contains(k));
    CHECK(sn[k].is_null());
  }
  CHECK(sn["target"] == json({{"distance", 0.0}, {"zero_info", json::array()}}));
  CHECK(sn["stopped_at_target"] == false);
  CHECK(sn["eval_wall_s"].get<double>() > 0);
  CHECK(sn["eval_share"].get<double>() > 0);
  CHECK(sn["eval_share"].get<double>() < 1);
  const ProgressCsv a = read_progress(never);
  REQUIRE(a.rows.size() == size_t(steps / 100));
  for (size_t r = 0; r < a.rows.size(); ++r)
    for (const char* k : {"time_to_target_s", "steps_to_target", "updates_to_target", "train_cost_to_target"})
      CHECK(a.at(r, k).empty());

  // A target just above a row m whose final distance is below every earlier
  // row's (the middle such row): m is the first evaluation that meets it,
  // and later ones meet it too (so "the first", not "the last", is tested).
  std::vector<size_t> records;
  double lowest = a.num(0, "final_distance");
  for (size_t r = 1; r < a.rows.size(); ++r)
    if (a.num(r, "final_distance") < lowest) {
      records.push_back(r);
      lowest = a.num(r, "final_distance");
    }
  REQUIRE(records.size() >= 2);  // the run learned something: later evaluations are nearer
  const size_t m = records[records.size() / 2];
  double earlier = INFINITY;
  for (size_t r = 0; r < m; ++r) earlier = std::min(earlier, a.num(r, "final_distance"));
  const double target = a.num(m, "final_distance") + 0.25 * (earlier - a.num(m, "final_distance"));
  size_t later = 0;
  for (size_t r = m + 1; r < a.rows.size(); ++r) later += a.num(r, "final_distance") <= target;
  REQUIRE(later >= 1);
  const json cfg = table_run(steps, target);
  const std::string full = tmp_dir("full");
  train(cfg, full);
  const ProgressCsv b = read_progress(full);
  REQUIRE(b.rows.size() == a.rows.size());
  for (size_t r = 0; r < b.rows.size(); ++r) CHECK(b.at(r, "final_distance") == a.at(r, "final_distance"));
  const json sb = json::parse(slurp(full + "/summary.json"));
  INFO("target " << target << ", first met at row " << m);
  CHECK(sb["steps_to_target"].get<double>() == b.num(m, "env_steps"));
  CHECK(sb["updates_to_target"].get<double>() == b.num(m, "updates"));
  CHECK(sb["train_cost_to_target"].get<double>() == b.num(m, "train_collision") + b.num(m, "train_violations"));
  CHECK(sb["train_cost_to_target"].get<double>() > 0);  // SAC without a safety layer: not a trivial 0
  CHECK(sb["train_cost_to_target"].get<double>() < sb["train_collisions"].get<double>() + sb["train_violations"].get<double>());
  CHECK(sb["time_to_target_s"].get<double>() == Approx(b.num(m, "wall_s")).epsilon(1e-8));
  CHECK(sb["time_to_target_s"].get<double>() <= sb["wall_s"].get<double>());
  for (size_t r = 0; r < b.rows.size(); ++r) {
    INFO("row " << r);
    if (r < m) {
      CHECK(b.at(r, "steps_to_target").empty());
      CHECK(b.at(r, "time_to_target_s").empty());
    } else {
      CHECK(b.num(r, "steps_to_target") == b.num(m, "env_steps"));
      CHECK(b.num(r, "updates_to_target") == b.num(m, "updates"));
      CHECK(b.at(r, "time_to_target_s") == b.at(m, "wall_s"));
      CHECK(b.num(r, "train_cost_to_target") == sb["train_cost_to_target"].get<double>());
    }
  }

  // Killed before the target was met, and after it (the met evaluation comes
  // back from the checkpoint): resumed == uninterrupted but for wall times.
  const int64_t met_at = sb["steps_to_target"].get<int64_t>();
  std::vector<int64_t> kills = {met_at - 50};
  if (met_at + 50 < steps) kills.push_back(met_at + 50);
  for (const int64_t kill : kills) {
    INFO("killed at " << kill);
    const std::string part = tmp_dir("part");
    REQUIRE(train(cfg, part, false, kill).env_steps == kill);
    REQUIRE(!fs::exists(part + "/summary.json"));
    train(cfg, part, true);
    CHECK(rows_without_wall(read_progress(part)) == rows_without_wall(b));
    CHECK(summary_without_wall(part) == summary_without_wall(full));
    fs::remove_all(part);
  }

  // --stop-at-target: ends at that row, with its summary and policy files.
  json stop_cfg = cfg;
  stop_cfg["train"]["stop_at_target"] = true;
  const std::string stop = tmp_dir("stop");
  const atacom::TrainSummary ss = train(stop_cfg, stop);
  CHECK(ss.stopped_at_target);
  CHECK(ss.env_steps == met_at);
  const ProgressCsv c = read_progress(stop);
  REQUIRE(c.rows.size() == m + 1);
  const auto rb = rows_without_wall(b), rc = rows_without_wall(c);
  for (size_t r = 0; r <= m; ++r) CHECK(rc[r] == rb[r]);
  const json sc = json::parse(slurp(stop + "/summary.json"));
  CHECK(sc["stopped_at_target"] == true);
  CHECK(sc["env_steps"] == met_at);
  CHECK(sc["steps_to_target"] == met_at);
  CHECK(sc["final_distance"].get<double>() <= target);
  CHECK(fs::exists(stop + "/policy_final.bin"));
  CHECK(fs::exists(stop + "/policy_best.bin"));
  // The run is done for a sweep, and resuming it (even with a larger budget) trains no further.
  atacom::SweepCell cell;
  cell.env = "table";
  cell.algo = "sac";
  cell.seed = 3;
  cell.steps = steps;
  const std::string sweep = tmp_dir("sweep");
  fs::create_directories(fs::path(sweep) / cell.run_dir());
  fs::copy(stop + "/summary.json", fs::path(sweep) / cell.run_dir() / "summary.json");
  CHECK(atacom::run_files_state(sweep, cell) == "done");
  fs::copy(never + "/summary.json", fs::path(sweep) / cell.run_dir() / "summary.json",
           fs::copy_options::overwrite_existing);
  cell.steps = 2 * steps;
  CHECK(atacom::run_files_state(sweep, cell) != "done");
  const json before = summary_without_wall(stop);
  json more = stop_cfg;
  more["train"]["steps"] = 2 * steps;
  const atacom::TrainSummary again = train(more, stop, true);
  CHECK(again.env_steps == met_at);
  CHECK(again.stopped_at_target);
  CHECK(summary_without_wall(stop) == before);
  CHECK(read_progress(stop).rows.size() == m + 1);
  for (const std::string& d : {never, full, stop, sweep}) fs::remove_all(d);
}

TEST_CASE("time to target: --stop-at-target on the command line and train.stop_at_target in a sweep spec", "[target]") {
  const atacom::SweepSpec spec = atacom::parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["atacom-sac"],
      "seeds": [0], "steps": 1000, "overrides": {"*/*": {"train": {"stop_at_target": true}}}})"));
  const auto cells = atacom::sweep_cells(spec);
  REQUIRE(cells.size() == 1);
  CHECK(atacom::resolve_run_config(cells[0].config()).train.stop_at_target);
  CHECK(!atacom::resolve_run_config(json::object()).train.stop_at_target);
  CHECK_THROWS_WITH(atacom::resolve_run_config({{"train", {{"stop_at_target", 1}}}}),
                    Catch::Contains("train.stop_at_target"));
  const std::string dir = tmp_dir("cli");
  const std::string cmd = std::string(ATACOM_ATACOM_EXE) + " train --env table --algo la --eval-episodes 2 --stop-at-target --out " +
                          dir + " > /dev/null 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const json cfg = json::parse(slurp(dir + "/config.json"));
  CHECK(cfg["train"]["stop_at_target"] == true);
  CHECK(cfg["env"]["target_distance"] == 0.05);
  const json s = json::parse(slurp(dir + "/summary.json"));
  CHECK(s.contains("time_to_target_s"));
  fs::remove_all(dir);
}
