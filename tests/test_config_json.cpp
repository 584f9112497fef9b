// ConfigReader's range-checked accessors, the strict JSON parser and the
// config structs that use them (issue 10 items 3 and 9).
#include <catch2/catch.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"

using nlohmann::json;
using namespace atacom;

TEST_CASE("config range: bounds read the way a user reads them", "[config]") {
  CHECK(range::closed(1, 1 << 20).describe() == "an integer in [1, 2^20]");
  CHECK(range::closed<int64_t>(1, 1'000'000'000'000).str() == "in [1, 10^12]");
  CHECK(range::at_least<int64_t>(0).describe() == "an integer >= 0");
  CHECK(range::positive().describe() == "a number > 0");
  CHECK(range::open_closed(0.0, 1.0).str() == "in (0, 1]");
  CHECK(range::closed_open(0.0, 0.2).str() == "in [0, 0.2)");
  CHECK(range::all<int>().str() == "in [-2^31, 2^31 - 1]");
  CHECK(range::all<uint64_t>().describe() == "an integer >= 0");
  CHECK(range::all<int64_t>().describe() == "an integer");
  CHECK(range::finite().describe() == "a number");
  // NaN and inf are never inside a floating range, even an unbounded one.
  CHECK_FALSE(range::finite().contains(std::numeric_limits<double>::infinity()));
  CHECK_FALSE(range::finite().contains(std::nan("")));
  CHECK(range::open(0.0, 1.0).contains(0.5));
  CHECK_FALSE(range::open(0.0, 1.0).contains(0.0));
}

TEST_CASE("config range: integers that do not fit are rejected, never wrapped or saturated", "[config]") {
  // Today's bug: get<int>() of 4294967298 gave 2.
  const json j = {{"n", 4294967298ll}, {"u", 18446744073709551615ull}, {"neg", -1}, {"f", 2.5}, {"big", 1e20}};
  ConfigReader r(j, "s");
  int n = 7;
  CHECK_THROWS_WITH(r.get("n", n), "config key 's.n' is 4294967298, must be an integer in [-2^31, 2^31 - 1]");
  CHECK(n == 7);
  int64_t u = 0;
  CHECK_THROWS_WITH(r.get("u", u), Catch::Contains("is 18446744073709551615"));
  uint64_t neg = 0;
  CHECK_THROWS_WITH(r.get("neg", neg), Catch::Contains("'s.neg' is -1"));
  CHECK_THROWS_WITH(r.integer("f", range::closed(0, 10)), "config key 's.f' is 2.5, must be an integer in [0, 10]");
  CHECK_THROWS_WITH(r.integer("big", range::closed<int64_t>(1, 1'000'000'000'000)),
                    "config key 's.big' is 1e+20, must be an integer in [1, 10^12]");
  double d = 0;
  CHECK_THROWS_WITH(r.get("n", d, range::closed(0.0, 1.0)), "config key 's.n' is 4294967298, must be a number in [0, 1]");
}

TEST_CASE("config range: the run config rejects out-of-range numbers naming key and range", "[config]") {
  const struct {
    json file;
    const char* expect;
  } cases[] = {
      {{{"train", {{"num_envs", 4294967298ll}}}}, "config key 'train.num_envs' is 4294967298, must be an integer in [1, 2^20]"},
      {{{"sac", {{"batch_size", 4294967360ll}}}}, "config key 'sac.batch_size' is 4294967360, must be an integer in [1, 2^16]"},
      {{{"train", {{"steps", 1e20}}}}, "config key 'train.steps' is 1e+20, must be an integer in [1, 10^12]"},
      {{{"train", {{"seed", -1}}}}, "config key 'train.seed' is -1, must be an integer >= 0"},
      {{{"sac", {{"tau", 0}}}}, "config key 'sac.tau' is 0, must be a number in (0, 1]"},
      {{{"sac", {{"replay_capacity", int64_t{1} << 40}}}}, "config key 'sac.replay_capacity' is 1099511627776, must be an integer in [1, 2^30]"},
      {{{"sac", {{"actor", {{"hidden", {256, 1 << 20}}}}}}}, "config key 'sac.actor.hidden[1]' is 1048576, must be an integer in [1, 8192]"},
      {{{"sac", {{"adam", {{"beta1", 1.0}}}}}}, "config key 'sac.adam.beta1' is 1.0, must be a number in [0, 1)"},
  };
  for (const auto& c : cases) {
    INFO(c.file.dump());
    CHECK_THROWS_WITH(resolve_run_config(c.file), c.expect);
  }
}

TEST_CASE("config: an unknown key lists the valid keys of its section", "[config]") {
  // the train section (ConfigReader), the env (merge_config_strict, nested too), the top level, a learner section
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"stepz", 3}}}}),
                    "unknown config key 'train.stepz' (valid keys of 'train': env, algo, seed, steps, num_envs, "
                    "eval_every, eval_episodes, eval_deterministic, checkpoint_every, preset, stop_at_target)");
  CHECK_THROWS_WITH(resolve_run_config({{"env", {{"gravity", 1}}}}),
                    Catch::StartsWith("unknown config key 'env.gravity' (valid keys of 'env': ") &&
                        Catch::Contains("horizon"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "nav"}}}, {"env", {{"room", {{"z", 1}}}}}}),
                    Catch::StartsWith("unknown config key 'env.room.z' (valid keys of 'env.room': ") &&
                        Catch::Contains("x") && Catch::Contains("y"));
  CHECK_THROWS_WITH(resolve_run_config({{"trian", json::object()}}),
                    Catch::StartsWith("unknown config key 'config.trian' (valid keys of 'config': ") &&
                        Catch::Contains("train") && Catch::Contains("env") && Catch::Contains("sac"));
  CHECK_THROWS_WITH(resolve_run_config({{"sac", {{"bach_size", 3}}}}),
                    Catch::StartsWith("unknown config key 'sac.bach_size' (valid keys of 'sac': ") &&
                        Catch::Contains("batch_size"));
}

TEST_CASE("config range: env sections carry their 'env.' prefix (arm, nav)", "[config]") {
  const struct {
    const char* env;
    json overrides;
    const char* expect;
  } cases[] = {
      {"pendulum", {{"horizon", 4294967297ll}}, "config key 'env.horizon' is 4294967297, must be an integer in [1, 10^7]"},
      {"pendulum", {{"dt", 0}}, "config key 'env.dt' is 0, must be a number in (0, 1]"},
      {"table", {{"dt", 2.0}}, "config key 'env.dt' is 2.0, must be a number in (0, 1)"},
      {"table", {{"horizon", 4294967298ll}}, "config key 'env.horizon' is 4294967298"},
      {"table", {{"constraints", {{"joint", {{"slack_tol", 1.0}}}}}}, "config key 'env.constraints.joint.slack_tol' is 1"},
      {"table", {{"constraints", {{"ground_poi", {3, 9}}}}}, "config key 'env.constraints.ground_poi[1]' is 9, must be an integer in [0, 8]"},
      {"shelf", {{"scene", {{"blend", 0.5}}}}, "config key 'env.scene.blend' is 0.5, must be a number in [0, 0.2)"},
      {"shelf", {{"goal_library_size", 1 << 30}}, "config key 'env.goal_library_size' is 1073741824, must be an integer in [1, 2^20]"},
      {"nav", {{"block", 0}}, "config key 'env.block' is 0, must be an integer in [1, 2^20]"},
      {"nav", {{"room", {{"x", -1.0}}}}, "config: env.room.x and room.y must be > 0"},
      {"nav", {{"box2d", {{"velocity_iterations", 1 << 30}}}}, "config key 'env.box2d.velocity_iterations' is 1073741824, must be an integer in [1, 1000]"},
  };
  for (const auto& c : cases) {
    INFO(c.env << " " << c.overrides.dump());
    CHECK_THROWS_WITH(make_env(EnvRequest{c.env, 1, SafetyLayer::None, c.overrides}), Catch::Contains(c.expect));
  }
}

TEST_CASE("config parse: duplicate keys and deep nesting are rejected, raw bytes never echoed", "[config]") {
  CHECK_THROWS_WITH(parse_json_strict(R"({"train": {"steps": 1, "steps": 2}})", "f"), "f: duplicate key 'train.steps'");
  CHECK_THROWS_WITH(parse_json_strict(R"({"a": 1, "b": [{"c": 1}, {"c": 2, "c": 3}]})", "f"),
                    "f: duplicate key 'b.c'");
  CHECK_NOTHROW(parse_json_strict(R"({"a": {"x": 1}, "b": {"x": 1}, "c": [{"x": 1}, {"x": 2}]})", "f"));
  CHECK_THROWS_WITH(parse_json_strict(std::string(100, '[') + std::string(100, ']'), "f"),
                    "f: nested deeper than 64 levels");
  try {
    parse_json_strict("{\"id\": \"\xff\xfe\"}", "f");
    FAIL("invalid UTF-8 accepted");
  } catch (const std::invalid_argument& e) {
    const std::string m = e.what();
    CHECK(m.find("not valid JSON") != std::string::npos);
    for (unsigned char ch : m) CHECK((ch >= 0x20 && ch < 0x7f));
    CHECK(m.find("\\xff") != std::string::npos);
    CHECK_NOTHROW(json(m).dump());
  }
}

TEST_CASE("config parse: read_json_file names a directory, a missing file and bad JSON", "[config]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("atacom_cfg_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  CHECK_THROWS_WITH(read_json_file(dir.string()), Catch::Contains("is a directory"));
  CHECK_THROWS_WITH(read_json_file((dir / "nope.json").string()), Catch::Contains("no such file"));
  std::ofstream(dir / "dup.json") << R"({"sac": {"tau": 0.1}, "sac": {}})";
  CHECK_THROWS_WITH(read_json_file((dir / "dup.json").string()), Catch::Contains("duplicate key 'sac'"));
  std::ofstream(dir / "ok.json") << R"({"train": {"steps": 5}})";
  CHECK(read_json_file((dir / "ok.json").string())["train"]["steps"] == 5);
  fs::remove_all(dir);
}
