// The command line as a newcomer meets it: every usage error exits 2, --help
// exits 0 and shows real defaults, --print-config prints the resolved config.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/trainer.hpp"
#include "shell_run.hpp"
#include "train/algorithms.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {
ShellResult atacom_cmd(const std::string& args) { return run_shell(std::string(ATACOM_ATACOM_EXE) + " " + args + " 2>&1"); }
}  // namespace

TEST_CASE("cli: every usage error exits 2 (CLI11's own codes were 105, 106, 109)", "[cli_usage]") {
  for (const char* args : {"", "nosuchcommand", "train --bogus", "rollout --env table --policy nope",
                           "rollout --env table --steps abc", "sdf-train --out /tmp/x", "render --env table",
                           "sweep --jobs 0 x.json", "filter --max-line-bytes -1", "report",
                           "train --env table --print-config --steps 0"}) {
    INFO(args);
    const ShellResult r = atacom_cmd(args);
    CHECK(r.rc == 2);
  }
  CHECK(atacom_cmd("--help").rc == 0);
  CHECK(atacom_cmd("train --help").rc == 0);
}

TEST_CASE("cli: train --help shows real defaults and names the registered envs and algorithms", "[cli_usage]") {
  const std::string h = atacom_cmd("train --help").out;
  const atacom::TrainConfig d = atacom::default_train_config();
  CHECK(h.find("--steps INT=" + std::to_string(d.steps)) != std::string::npos);
  CHECK(h.find("--envs INT=" + std::to_string(d.num_envs)) != std::string::npos);
  CHECK(h.find("--env TEXT=" + d.env) != std::string::npos);
  CHECK(h.find("=-1") == std::string::npos);
  CHECK(h.find("default: train.") == std::string::npos);
  for (const std::string& e : atacom::env_names()) CHECK(h.find(e) != std::string::npos);
  for (const std::string& a : atacom::algorithm_names()) CHECK(h.find(a) != std::string::npos);
  CHECK(h.find("eval_episode_max_constraint") != std::string::npos);  // the safety numbers are defined in help
  CHECK(h.find("info[\"cost\"]") != std::string::npos);
  for (const char* sub : {"sdf-train", "sweep"}) {
    INFO(sub);
    CHECK(atacom_cmd(std::string(sub) + " --help").out.find("=-1") == std::string::npos);
  }
}

TEST_CASE("cli: train --print-config prints resolve_run_config's result, which the run then writes", "[cli_usage]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_cli_usage_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const std::string cfg = dir + ".json";
  std::ofstream(cfg) << R"({"sac": {"batch_size": 16, "initial_replay": 50, "warmup": 50, "actor": {"hidden": [8]},
                            "critic": {"hidden": [8]}}, "train": {"eval_episodes": 2}})";
  const ShellResult r = atacom_cmd("train --config " + cfg + " --env pendulum --algo sac --steps 120 --print-config");
  REQUIRE(r.rc == 0);
  const json printed = json::parse(r.out);
  json file = json::parse(std::ifstream(cfg));
  file["train"]["env"] = "pendulum";
  file["train"]["algo"] = "sac";
  file["train"]["steps"] = 120;
  CHECK(printed == atacom::run_config_json(atacom::resolve_run_config(file)));
  CHECK(printed["train"]["eval_every"] == 1000);  // the default for runs under 50k steps
  CHECK(printed["sac"]["batch_size"] == 16);
  CHECK(printed["sac"].contains("lr_actor"));     // every key, defaults filled in
  CHECK(!fs::exists(dir));                        // nothing written, no --out needed
  REQUIRE(atacom_cmd("--threads 1 train --config " + cfg + " --env pendulum --algo sac --steps 120 --out " + dir).rc == 0);
  json written = json::parse(std::ifstream(dir + "/config.json"));
  written.erase("host");
  CHECK(written == printed);
  fs::remove_all(dir);
  fs::remove(cfg);
}

TEST_CASE("config: eval_every defaults to 1000 under 50k steps, 10000 from 50k, unless set", "[cli_usage]") {
  CHECK(atacom::default_eval_every(20000) == 1000);
  CHECK(atacom::default_eval_every(49999) == 1000);
  CHECK(atacom::default_eval_every(50000) == 10000);
  auto resolved = [](const json& train) {
    return atacom::resolve_run_config({{"train", train}}).train.eval_every;
  };
  CHECK(resolved({{"steps", 20000}}) == 1000);
  CHECK(resolved({{"steps", 2000000}}) == 10000);
  CHECK(resolved({{"steps", 20000}, {"eval_every", 5000}}) == 5000);
  CHECK(resolved(json::object()) == 10000);  // the default 100k steps
}
