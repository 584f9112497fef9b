// The --sdf flag on the command line: applied on hri (the learned human),
// refused clearly with --policy trained and --resume (the run's own env
// config decides there) and on envs without a shipped model; sdf-train
// trains the robot body, and a missing body file stops rollout at once.
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "tests/shell_run.hpp"

namespace fs = std::filesystem;

namespace {
using Result = ShellResult;
Result sdf_cli(const std::string& args) { return run_shell(std::string(ATACOM_ATACOM_EXE) + " " + args + " 2>&1"); }
}  // namespace

TEST_CASE("sdf cli: --sdf learned runs hri with the learned human, and is refused with --policy trained, --resume, nav", "[redsdf][cli]") {
  const Result ok = sdf_cli("--threads 1 rollout --env hri --policy random --steps 800 --envs 8 --seed 2 --sdf learned");
  INFO(ok.out);
  REQUIRE(ok.rc == 0);
  const auto j = nlohmann::json::parse(ok.out.substr(ok.out.find('{')));
  CHECK(j["steps"] == 800);
  CHECK(j["nonfinite_constraints"] == 0);

  const Result trained = sdf_cli("rollout --policy trained --run /nonexistent/run --sdf learned");
  CHECK(trained.rc != 0);
  CHECK_THAT(trained.out, Catch::Contains("--sdf does not apply to --policy trained"));

  const fs::path dir = fs::temp_directory_path() / ("atacom_sdf_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "config.json") << "{}\n";
  const Result resume = sdf_cli("train --resume --out " + dir.string() + " --sdf learned");
  fs::remove_all(dir);
  CHECK(resume.rc != 0);
  CHECK_THAT(resume.out, Catch::Contains("--sdf cannot be combined with --resume"));

  const Result nav = sdf_cli("rollout --env nav --policy random --steps 10 --envs 1 --sdf learned");
  CHECK(nav.rc != 0);
  CHECK_THAT(nav.out, Catch::Contains("no field with a shipped learned model"));

}

TEST_CASE("sdf cli: sdf-train --object tiago writes a body model, a bad body file stops rollout before any step", "[redsdf][cli]") {
  const fs::path dir = fs::temp_directory_path() / ("atacom_sdf_tiago_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const Result tiago = sdf_cli("--threads 1 sdf-train --object tiago --out " + (dir / "m").string() +
                                  " --epochs 1 --surface-points 2 --hidden 16,16,16 --batch 256 --quiet");
  INFO(tiago.out);
  REQUIRE(tiago.rc == 0);
  std::ifstream mf(dir / "m" / "manifest.json");
  const auto man = nlohmann::json::parse(mf);
  CHECK(man["object"] == "tiago");
  CHECK(man["arch"]["pose_dim"] == 1);
  CHECK_THAT(man["command"].get<std::string>(), Catch::Contains("--object tiago"));
  for (const char* f : {"redsdf.bin", "progress.csv", "learning_curve.svg", "config.json"}) CHECK(fs::exists(dir / "m" / f));

  std::ofstream(dir / "bad.json") << R"({"sdf": {"tiago": "learned:)" << (dir / "missing").string() << "\"}}\n";
  const Result bad = sdf_cli("rollout --env shelf --policy random --steps 10 --envs 1 --config " + (dir / "bad.json").string());
  fs::remove_all(dir);
  CHECK(bad.rc != 0);
  CHECK_THAT(bad.out, Catch::Contains("cannot be opened"));
}
