// atacom report's ShelfEnvReal section: every finished shelf policy through
// the protocol, with its own layer and the same trials, equal to running the
// protocol on the run's policy directly; runs it cannot evaluate are listed
// with the reason, never dropped silently.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <map>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"
#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/shelf_real.hpp"
#include "src/experiments/report.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/csv_rows.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

// A run directory with only a summary covering `steps` (the report counts it finished).
void fake_run(const fs::path& run, int64_t steps) {
  fs::create_directories(run);
  std::ofstream(run / "summary.json") << json{{"env_steps", steps}, {"eval_return_mean", -100.0},
                                              {"final_distance", 0.5}}.dump();
  std::ofstream(run / "config.json") << json{{"env", json::object()}}.dump();
}

}  // namespace

TEST_CASE("report: every finished shelf policy goes through the ShelfEnvReal protocol", "[report][shelf_real]") {
  const fs::path dir = fs::temp_directory_path() / ("atacom_report_shelf_real_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const int64_t steps = 400;
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["shelf"],
      "algos": ["atacom-sac", "safelayer-sac", "la-atacom"], "seeds": [0, 1, 2], "steps": 400})"));
  save_or_check_spec(dir.string(), spec);
  // atacom-sac seeds 0 and 1 and safelayer-sac seed 0 train for real (too
  // short to learn: the policy is its initialisation, which differs by
  // seed); the other seeds have no policy file.
  auto train = [&](const std::string& algo, int s) {
    TrainOptions o;
    o.out_dir = (dir / ("runs/shelf/" + algo + "/seed-" + std::to_string(s))).string();
    run_training(resolve_run_config(json{{"train", {{"env", "shelf"}, {"algo", algo}, {"seed", s},
                                                    {"steps", steps}, {"num_envs", 2}, {"eval_every", steps},
                                                    {"eval_episodes", 1}}}}),
                 o);
  };
  for (int s : {0, 1}) train("atacom-sac", s);
  train("safelayer-sac", 0);
  fake_run(dir / "runs/shelf/atacom-sac/seed-2", steps);
  for (int s : {1, 2}) fake_run(dir / ("runs/shelf/safelayer-sac/seed-" + std::to_string(s)), steps);
  for (int s : {0, 1, 2}) fake_run(dir / ("runs/shelf/la-atacom/seed-" + std::to_string(s)), steps);
  ReportOptions ro;
  ro.dir = dir.string();
  write_report(ro);

  const auto rows = csv_rows::read(dir / "report/shelf_real.csv");
  std::map<std::string, std::vector<std::map<std::string, std::string>>> by;  // "algo/seed"
  for (const auto& r : rows) by[r.at("algo") + "/" + r.at("seed")].push_back(r);
  // Trained runs: the same numbers as the protocol on the run's policy, through ATACOM.
  for (int s : {0, 1}) {
    INFO("atacom-sac seed " << s);
    const auto tp = TrainedPolicy::load((dir / ("runs/shelf/atacom-sac/seed-" + std::to_string(s))).string());
    ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
    from_json(tp->config().env, ec);
    const ShelfRealResult want = evaluate_shelf_real(ec, default_shelf_real_config(), *tp);
    const auto& got = by["atacom-sac/" + std::to_string(s)];
    REQUIRE(got.size() == 2);
    for (int t = 0; t < 2; ++t) {
      CHECK(got[t].at("safety") == "atacom");
      CHECK(got[t].at("target") == std::to_string(t + 1));
      CHECK(std::stod(got[t].at("success_rate")) == Approx(want.targets[t].success_rate).epsilon(1e-11));
      CHECK(std::stod(got[t].at("final_error_mean")) == Approx(want.targets[t].final_error_mean).epsilon(1e-11));
      CHECK(std::stoi(got[t].at("collisions")) == want.targets[t].collisions);
      CHECK(got[t].at("skipped").empty());
    }
  }
  // The two seeds' policies differ, so the rows must too (the right file per run).
  CHECK(by["atacom-sac/0"][0].at("final_error_mean") != by["atacom-sac/1"][0].at("final_error_mean"));
  // Not evaluated, with the reason.
  REQUIRE(by["atacom-sac/2"].size() == 1);
  CHECK(by["atacom-sac/2"][0].at("skipped").find("no policy_final.bin") != std::string::npos);
  // A SafeLayer policy goes through SafeLayer, as it trained.
  {
    const auto tp = TrainedPolicy::load((dir / "runs/shelf/safelayer-sac/seed-0").string());
    ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
    from_json(tp->config().env, ec);
    ShelfRealConfig c = default_shelf_real_config();
    c.layer = ShelfRealLayer::SafeLayer;
    const ShelfRealResult want = evaluate_shelf_real(ec, c, *tp);
    const auto& got = by["safelayer-sac/0"];
    REQUIRE(got.size() == 2);
    for (int t = 0; t < 2; ++t) {
      CHECK(got[t].at("safety") == "safelayer");
      CHECK(std::stod(got[t].at("final_error_mean")) == Approx(want.targets[t].final_error_mean).epsilon(1e-11));
      CHECK(std::stoi(got[t].at("collisions")) == want.targets[t].collisions);
      CHECK(got[t].at("skipped").empty());
    }
    // Not the ATACOM answer for the same policy (the layer was applied).
    c.layer = ShelfRealLayer::Atacom;
    CHECK(evaluate_shelf_real(ec, c, *tp).targets[0].final_error_mean != Approx(want.targets[0].final_error_mean));
  }
  for (int s : {1, 2}) {
    const auto& sl = by["safelayer-sac/" + std::to_string(s)];
    REQUIRE(sl.size() == 1);
    CHECK(sl[0].at("skipped").find("no policy_final.bin") != std::string::npos);
  }
  // The attractor is deterministic: one evaluation (its first seed), through ATACOM, no collision.
  CHECK(by.count("la-atacom/1") == 0);
  CHECK(by.count("la-atacom/2") == 0);
  ArmAttractorPolicy la(default_arm_env_config(ArmTask::Shelf));
  const ShelfRealResult la_want = evaluate_shelf_real(default_arm_env_config(ArmTask::Shelf), default_shelf_real_config(), la);
  const auto& lr = by["la-atacom/0"];
  REQUIRE(lr.size() == 2);
  for (int t = 0; t < 2; ++t) {
    CHECK(std::stod(lr[t].at("success_rate")) == Approx(la_want.targets[t].success_rate).epsilon(1e-11));
    CHECK(lr[t].at("collisions") == "0");
  }
  const std::string md = slurp(dir / "report/summary.md");
  CHECK(md.find("## ShelfEnvReal") != std::string::npos);
  CHECK(md.find("| la-atacom | atacom | 1 (deterministic) |") != std::string::npos);
  CHECK(md.find("| atacom-sac | atacom | 2 | ") != std::string::npos);
  CHECK(md.find("n = 2: no interval") != std::string::npos);
  CHECK(md.find("| safelayer-sac | safelayer | 1 | ") != std::string::npos);
  CHECK(md.find("- safelayer-sac (seeds 1, 2): no policy") != std::string::npos);
  fs::remove_all(dir);
}
