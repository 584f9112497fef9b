// The --sdf flag on the command line: applied on hri (the learned human),
// refused clearly with --policy trained and --resume (the run's own env
// config decides there) and on envs without a shipped model; sdf-train
// refuses the robot body (not implemented) by name.
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;

namespace {
struct Result {
  int rc = -1;
  std::string out;
};
Result atacom_cli(const std::string& args) {
  const std::string cmd = std::string(ATACOM_ATACOM_EXE) + " " + args + " 2>&1";
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof(buf), p)) r.out.append(buf, n);
  const int status = pclose(p);
  r.rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}
}  // namespace

TEST_CASE("sdf cli: --sdf learned runs hri with the learned human, and is refused with --policy trained, --resume, nav", "[redsdf][cli]") {
  const Result ok = atacom_cli("--threads 1 rollout --env hri --policy random --steps 800 --envs 8 --seed 2 --sdf learned");
  INFO(ok.out);
  REQUIRE(ok.rc == 0);
  const auto j = nlohmann::json::parse(ok.out.substr(ok.out.find('{')));
  CHECK(j["steps"] == 800);
  CHECK(j["nonfinite_constraints"] == 0);

  const Result trained = atacom_cli("rollout --policy trained --run /nonexistent/run --sdf learned");
  CHECK(trained.rc != 0);
  CHECK_THAT(trained.out, Catch::Contains("--sdf does not apply to --policy trained"));

  const fs::path dir = fs::temp_directory_path() / ("atacom_sdf_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "config.json") << "{}\n";
  const Result resume = atacom_cli("train --resume --out " + dir.string() + " --sdf learned");
  fs::remove_all(dir);
  CHECK(resume.rc != 0);
  CHECK_THAT(resume.out, Catch::Contains("--sdf cannot be combined with --resume"));

  const Result nav = atacom_cli("rollout --env nav --policy random --steps 10 --envs 1 --sdf learned");
  CHECK(nav.rc != 0);
  CHECK_THAT(nav.out, Catch::Contains("no field with a shipped learned model"));

  const Result tiago = atacom_cli("sdf-train --object tiago --out " + (fs::temp_directory_path() / "atacom_sdf_tiago").string());
  CHECK(tiago.rc != 0);
  CHECK_THAT(tiago.out, Catch::Contains("--object tiago: the robot-body field is not implemented"));
}
