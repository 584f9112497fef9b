// `atacom sweep --dry-run`: works without --out, writes nothing, prints no
// paths it will not write, and estimates the cost from the measured rates
// (src/experiments/sweep_cost.hpp, data/sweep_rates.json).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "shell_run.hpp"
#include "src/core/config_json.hpp"
#include "src/core/data_dir.hpp"
#include "src/experiments/sweep_cost.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

TEST_CASE("sweep cost: a cell's seconds from the measured rates", "[sweep_cost]") {
  const json rates = read_json_file(data_file("sweep_rates.json"));
  REQUIRE(rates.contains("command"));  // the table names the command that measured it
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["atacom-sac", "la-atacom"],
      "seeds": [0], "steps": 20000, "num_envs": 4, "overrides": {"*/*": {"train": {"eval_every": 1000, "eval_episodes": 5}}}})"));
  const auto cells = sweep_cells(spec);
  double collect = NAN, train = NAN, eval = NAN;
  for (const json& r : rates.at("rates"))
    if (r.at("env") == "table" && r.at("safety") == "atacom")
      collect = r.at("collect_per_s").get<double>(), train = r.at("train_per_s").get<double>(),
      eval = r.at("eval_per_s").get<double>();
  REQUIRE(std::isfinite(train));
  // atacom-sac: 5000 steps before the first update at the collect rate, 15000 at the training rate,
  // 20 evaluations of 5 episodes of the 500-step horizon.
  CHECK(estimate_cell_seconds(cells[0]) == Approx(5000 / collect + 15000 / train + 20 * 5 * 500 / eval));
  CHECK(estimate_cell_seconds(cells[1]) == Approx(5 * 500 / eval));  // one evaluation
  const SweepCost c = estimate_sweep_cost(cells);
  CHECK(c.run_seconds == Approx(estimate_cell_seconds(cells[0]) + estimate_cell_seconds(cells[1])));
  CHECK(c.unknown == 0);
  CHECK(c.source.find("sweep_rates.sh") != std::string::npos);
}

TEST_CASE("sweep cost: a learner's update seconds scale with its work per env step, CBF takes SafeLayer's rates",
          "[sweep_cost]") {
  auto seconds = [](const std::string& algo, const json& overrides) {
    json j = {{"envs", {"table"}}, {"algos", {algo}}, {"seeds", {0}}, {"steps", 100000}, {"num_envs", 4},
              {"overrides", {{"*/*", overrides}}}};
    j["overrides"]["*/*"]["train"] = {{"eval_every", 100000}, {"eval_episodes", 1}};
    return estimate_cell_seconds(sweep_cells(parse_sweep_spec(j))[0]);
  };
  const double base = seconds("atacom-sac", json::object());
  // Half the updates: the update part halves (the collect part stays).
  const double half = seconds("atacom-sac", {{"sac", {{"updates_per_step", 0.5}}}});
  const double none = seconds("atacom-sac", {{"sac", {{"updates_per_step", 1e-9}}}});
  CHECK(half == Approx(0.5 * (base + none)).epsilon(1e-6));
  // Twice the batch: the update part doubles.
  CHECK(seconds("atacom-sac", {{"sac", {{"batch_size", 128}}}}) == Approx(2 * base - none).epsilon(1e-6));
  // The Lagrangian's cost critics add work; CBF is SafeLayer's QP with another right-hand side.
  CHECK(seconds("sac-lag", json::object()) > seconds("sac", json::object()));
  CHECK(seconds("cbf-sac", json::object()) == Approx(seconds("safelayer-sac", json::object())));
  // PPO's work grows with its epochs.
  CHECK(seconds("atacom-ppo", {{"ppo", {{"epochs", 10}}}}) > seconds("atacom-ppo", {{"ppo", {{"epochs", 5}}}}));
}

TEST_CASE("sweep --dry-run without --out: the cells and the estimate, nothing written, no paths", "[sweep_cost]") {
  const fs::path dir = fs::temp_directory_path() / ("atacom_sweep_cost_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "cwd");
  std::ofstream(dir / "spec.json") << R"({"envs": ["table", "nav"], "algos": ["sac", "la"], "seeds": [0, 1],
                                         "steps": 20000, "num_envs": 4})";
  const ShellResult r = run_shell("cd " + (dir / "cwd").string() + " && " + ATACOM_ATACOM_EXE + " sweep " +
                                  (dir / "spec.json").string() + " --dry-run --jobs 2 2>&1");
  INFO(r.out);
  REQUIRE(r.rc == 0);
  CHECK(r.out.find("sweep: 8 runs, 2 at a time") != std::string::npos);
  CHECK(r.out.find("table-sac-seed1  to run\n") != std::string::npos);
  CHECK(r.out.find("estimate: ") != std::string::npos);
  CHECK(r.out.find("core time, about ") != std::string::npos);
  CHECK(r.out.find("runs/") == std::string::npos);
  CHECK(r.out.find("inputs/") == std::string::npos);
  CHECK(r.out.find("--out") == std::string::npos);
  CHECK(fs::is_empty(dir / "cwd"));
  // without --dry-run, --out is still required
  const ShellResult w = run_shell(std::string(ATACOM_ATACOM_EXE) + " sweep " + (dir / "spec.json").string() + " 2>&1");
  CHECK(w.rc == 2);
  CHECK(w.out.find("--out DIR is required") != std::string::npos);
  fs::remove_all(dir);
}
