// The `atacom` executable against hostile input, with the reproducers of
// issue 10: every filter line gets exactly one answer (items 1, 8, 9), every
// integer flag is range-checked by name (item 3), a lost write on stdout is
// an error exit (item 4), and a run's start removes temp files a killed
// process left (item 5).
#include <catch2/catch.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "atacom/trainer.hpp"
#include "src/core/limits.hpp"
#include "src/core/value_range.hpp"
#include "src/safety/filter.hpp"
#include "tests/build_kind.hpp"
#include "tests/shell_run.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using Result = ShellResult;  // out: stdout (and stderr when merged)

// Runs `atacom <args>` through the shell; `stdin_text` is fed from a file.
// `stdout_to` other than "" sends stdout there and reads stderr instead.
Result atacom_cli(const std::string& args, const std::string& stdin_text = "", bool merge_stderr = true,
                  const std::string& stdout_to = "") {
  const fs::path in = fs::temp_directory_path() / ("atacom_hostile_in_" + std::to_string(::getpid()));
  std::ofstream(in, std::ios::binary) << stdin_text;
  const std::string cmd = std::string(ATACOM_ATACOM_EXE) + " " + args + " < " + in.string() +
                          (!stdout_to.empty() ? " 2>&1 >" + stdout_to : merge_stderr ? " 2>&1" : " 2>/dev/null");
  const Result r = run_shell(cmd);
  fs::remove(in);
  return r;
}

std::vector<json> lines_of(const std::string& text) {
  std::vector<json> v;
  std::istringstream s(text);
  std::string l;
  while (std::getline(s, l)) v.push_back(json::parse(l));  // every answer is valid JSON
  return v;
}

const std::string kValid = R"({"f":[0],"G":[[1]],"J_q":[],"c":[],"alpha":[1]})";

}  // namespace

TEST_CASE("hostile filter: invalid UTF-8 gives an error line for that line and the stream goes on", "[hostile]") {
  // The issue's reproducer: before, no answer at all, a type_error.316 and exit 2.
  const Result r = atacom_cli("filter", "{\"id\":\"\xff\"}\n" + kValid + "\n", false);
  CHECK(r.rc == 1);
  const auto a = lines_of(r.out);
  REQUIRE(a.size() == 2);
  CHECK(a[0]["line"] == 1);
  CHECK(a[0]["error"].get<std::string>().find("UTF-8") != std::string::npos);
  CHECK(a[0]["error"].get<std::string>().find("\\xff") != std::string::npos);  // escaped, never raw
  CHECK(a[1].contains("a"));
  // Invalid sequences anywhere: lone continuation, overlong, surrogate, truncated, in a key.
  for (const std::string& bad : std::vector<std::string>{"{\"f\":\"\x80\"}", "{\"f\":\"\xc0\xaf\"}", "{\"f\":\"\xed\xa0\x80\"}",
                                "{\"f\":\"\xe2\x82\"}", "{\"\xfe\":1}", "\xff\xfe", std::string("{\"f\":\"\0\"}", 10)}) {
    std::string out;
    CHECK_FALSE(atacom::filter_line(bad, 7, out));
    const json e = json::parse(out);
    CHECK(e["line"] == 7);
  }
}

TEST_CASE("hostile filter: every line gets exactly one answer, a blank line an error answer", "[hostile]") {
  const Result r = atacom_cli("filter", "\n" + kValid + "\n   \n\r\n" + kValid + "\n", false);
  CHECK(r.rc == 1);
  const auto a = lines_of(r.out);
  REQUIRE(a.size() == 5);
  for (int i : {0, 2, 3}) {
    CHECK(a[size_t(i)]["line"] == i + 1);
    CHECK(a[size_t(i)]["error"].get<std::string>().find("blank line") != std::string::npos);
  }
  CHECK(a[1].contains("a"));
  CHECK(a[4].contains("a"));
  // No trailing newline on the last line: still answered.
  CHECK(lines_of(atacom_cli("filter", kValid, false).out).size() == 1);
}

TEST_CASE("hostile filter: 3000 mixed hostile lines, one valid JSON answer each, never a crash", "[hostile]") {
  atacom::Rng rng(10, 0);
  const std::vector<std::string> seeds = {
      kValid, R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-0.001],"alpha":[1,0.5],"id":"x"})",
      R"({"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[1],"J_x":[[1]],"xdot":[0.5],"slack":"exponential"})"};
  std::string in;
  for (int i = 0; i < 3000; ++i) {
    std::string l = seeds[size_t(i) % seeds.size()];
    const int edits = int(rng.uniform() * 6);
    for (int e = 0; e < edits && !l.empty(); ++e) {
      const size_t at = size_t(rng.uniform() * double(l.size())) % l.size();
      const char c = static_cast<char>(int(rng.uniform() * 256) & 0xff);
      if (c == '\n') continue;  // one input line stays one line
      if (rng.uniform() < 0.5) l[at] = c;
      else l.insert(at, 1, c);
    }
    in += l + "\n";
  }
  std::istringstream is(in);
  std::ostringstream os;
  const long failed = atacom::run_filter(is, os);
  const auto a = lines_of(os.str());
  REQUIRE(a.size() == 3000);
  long errors = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    REQUIRE((a[i].contains("a") || a[i].contains("error")));
    if (a[i].contains("error")) {
      ++errors;
      CHECK(a[i]["line"] == long(i) + 1);
    }
  }
  CHECK(errors == failed);
  CHECK(errors > 0);
  CHECK(errors < 3000);
}

TEST_CASE("hostile filter: a line above the limit gets an error answer and is not kept", "[hostile]") {
  std::string big = "{\"f\":[";
  for (int i = 0; i < 200000; ++i) big += "0,";
  big += "0]}";
  std::istringstream is(big + "\n" + kValid + "\n");
  std::ostringstream os;
  CHECK(atacom::run_filter(is, os, 1000) == 1);
  const auto a = lines_of(os.str());
  REQUIRE(a.size() == 2);
  CHECK(a[0]["error"].get<std::string>().find("longer than the limit of 1000") != std::string::npos);
  CHECK(a[1].contains("a"));
  // The flag: its range by name.
  const Result r = atacom_cli("filter --max-line-bytes 0");
  CHECK(r.rc != 0);
  CHECK(r.out.find("--max-line-bytes: 0 is not an integer in [1, 2^30]") != std::string::npos);
  CHECK(lines_of(atacom_cli("filter --max-line-bytes 10", kValid + "\n", false).out)[0]["error"] != nullptr);
}

TEST_CASE("hostile filter: dimension limits, duplicate keys, J_x with an empty xdot", "[hostile]") {
  auto error_of = [](const std::string& line) {
    std::string out;
    CHECK_FALSE(atacom::filter_line(line, 1, out));
    return json::parse(out)["error"].get<std::string>();
  };
  std::string f = "[0";
  for (int i = 0; i < 1024; ++i) f += ",0";
  f += "]";
  CHECK(error_of(R"({"f":)" + f + R"(,"G":[],"J_q":[],"c":[],"alpha":[1]})").find("more than the limit of 1024") !=
        std::string::npos);
  CHECK(error_of(R"({"f":[0],"f":[1],"G":[[1]],"J_q":[],"c":[],"alpha":[1]})").find("duplicate key 'f'") !=
        std::string::npos);
  // Before: J_x was accepted unvalidated when xdot was empty.
  CHECK(error_of(R"({"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[1],"J_x":"junk","xdot":[]})")
            .find("'J_x'") != std::string::npos);
  CHECK(error_of(R"({"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[1],"J_x":[[1]],"xdot":[]})")
            .find("'J_x' must be 1 x 0") != std::string::npos);
  CHECK(error_of(R"({"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[1],"J_x":[[1]],"xdot":5})")
            .find("'xdot' must be an array") != std::string::npos);
  std::string ok;
  CHECK(atacom::filter_line(R"({"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[1],"J_x":[[]],"xdot":[]})", 1, ok));
  // Deep nesting (an id) is refused before anything recurses over it.
  CHECK(error_of(R"({"id":)" + std::string(5000, '[') + std::string(5000, ']') + "}").find("nested deeper") !=
        std::string::npos);
}

TEST_CASE("hostile flags: every integer flag is range-checked with its name and range", "[hostile]") {
  struct Case {
    std::string args, expect;
  };
  const std::vector<Case> cases = {
      {"train --steps 99999999999999999999 --out /nonexistent/x", "--steps: 99999999999999999999 is not an integer in [1, 10^12]"},
      {"train --steps 1e20 --out /nonexistent/x", "--steps: 1e20 is not an integer in [1, 10^12]"},
      {"train --seed -1 --out /nonexistent/x", "--seed: -1 is not an integer >= 0"},
      {"train --envs 4294967298 --out /nonexistent/x", "--envs: 4294967298 is not an integer in [1, 2^20]"},
      {"rollout --env nav --steps 9223372036854775807", "--steps: 9223372036854775807 is not an integer in [1, 10^12]"},
      {"rollout --env nav --seed -1", "--seed: -1 is not an integer in [0, 2^63 - 1]"},
      {"rollout --env nav --envs 100000000", "--envs: 100000000 is not an integer in [1, 2^20]"},
      {"rollout --env nav --steps 12abc", "--steps: 12abc is not an integer"},
      {"attack --env nav --steps 0 --out /nonexistent/x", "--steps: 0 is not an integer in [1, 10^12]"},
      {"shelf-real --trials 1000000", "--trials: 1000000 is not an integer in [1, 100000]"},
      {"shelf-real --seed 18446744073709551615", "--seed: 18446744073709551615 is not an integer in [0, 2^63 - 1]"},
      {"demo --envs -3", "--envs: -3 is not an integer in [1, 2^20]"},
      {"--threads 100000 rollout --env nav", "--threads: 100000 is not an integer in [0, 1024]"},
  };
  for (const Case& c : cases) {
    const Result r = atacom_cli(c.args);
    INFO(c.args << " -> " << r.out);
    CHECK(r.rc != 0);
    CHECK(r.out.find(c.expect) != std::string::npos);
    CHECK(r.out.find("00000000000000000000000000") == std::string::npos);  // never a 309-digit bound
  }
  // More threads than cores: clamped and said, never echoed as if used.
  const Result r = atacom_cli("--threads 1024 rollout --env nav --policy zero --steps 10 --envs 2", "", false);
  REQUIRE(r.rc == 0);
  CHECK(json::parse(r.out)["threads"].get<int>() < 1024);
  // Defaults are shown.
  CHECK(atacom_cli("rollout --help").out.find("--steps INT=100000") != std::string::npos);
}

// Issue 28 item 10: numeric flags outside the checked parser read "00017" as
// octal 15, saturated 2^64 to 2^63 - 1, took "0x10" as 16 and "nan" as the
// default. The one parser, then every flag of every subcommand through it.
TEST_CASE("hostile flags: the one numeric flag parser reads decimal text whole, in range, never NaN", "[hostile]") {
  using atacom::parse_flag_value;
  namespace range = atacom::range;
  const auto seeds = range::closed<int64_t>(0, std::numeric_limits<int64_t>::max());
  CHECK(parse_flag_value<int64_t>("--seed", "00017", seeds) == 17);
  CHECK(parse_flag_value<int>("--epochs", "010", range::closed(1, 100)) == 10);
  CHECK(parse_flag_value<int64_t>("--seed", "+5", seeds) == 5);
  CHECK_THROWS_WITH(parse_flag_value<int64_t>("--seed", "18446744073709551616", seeds),
                    "--seed: 18446744073709551616 is not an integer >= 0");
  CHECK_THROWS_WITH(parse_flag_value<int64_t>("--seed", "9223372036854775808", seeds),
                    "--seed: 9223372036854775808 is not an integer >= 0");
  CHECK_THROWS_WITH(parse_flag_value<int>("--patience", "0x10", range::closed(1, 100)),
                    "--patience: 0x10 is not an integer in [1, 100]");
  CHECK_THROWS_WITH(parse_flag_value<uint64_t>("--bootstrap-seed", "-1", range::closed<uint64_t>(0, 100)),
                    "--bootstrap-seed: -1 is not an integer in [0, 100]");
  for (const char* bad : {"+-5", "-+5", " 5", "5 ", "1e3", "", "5\x01"})
    CHECK_THROWS(parse_flag_value<int>("--jobs", bad, range::closed(1, 4096)));
  CHECK(parse_flag_value<double>("--lr", "1e-3", range::open_closed(0.0, 1.0)) == 1e-3);
  CHECK(parse_flag_value<double>("--lr", ".5", range::open_closed(0.0, 1.0)) == 0.5);
  for (const char* bad : {"nan", "NaN", "inf", "-inf", "infinity", "0x1p-3", "1e400", "1,5", "0.5x"})
    CHECK_THROWS_WITH(parse_flag_value<double>("--lr", bad, range::open_closed(0.0, 1.0)),
                      Catch::StartsWith(std::string("--lr: ")) && Catch::EndsWith("is not a number in (0, 1]"));
}

TEST_CASE("hostile flags: every numeric flag of every subcommand goes through the one range-checked parser",
          "[hostile]") {
  // Subcommands from `atacom --help`, their numeric flags from `atacom SUB --help` (CLI11's type names).
  std::vector<std::string> subs = {""};
  {
    std::istringstream help(atacom_cli("--help").out);
    bool in_subs = false;
    for (std::string line; std::getline(help, line);) {
      if (line.rfind("SUBCOMMANDS:", 0) == 0 || line.rfind("Subcommands:", 0) == 0) in_subs = true;
      else if (in_subs && line.size() > 2 && line[0] == ' ' && line[1] == ' ' && line[2] != ' ')
        subs.push_back(line.substr(2, line.find(' ', 2) - 2));
      else if (in_subs && !line.empty() && line[0] != ' ') in_subs = false;
    }
  }
  REQUIRE(subs.size() >= 13);
  // The type is a whole word ("--stats Excludes: --out" is a flag without one, not of type "E").
  const std::regex option(R"(^\s+(?:-\w, )?(--[a-z0-9-]+)(?:,[^ ]*)? ([A-Z][A-Z0-9_:]*)(?=[= ]|$))");
  int numeric = 0;
  for (const std::string& sub : subs) {
    std::vector<std::string> lines;
    {
      std::istringstream help(atacom_cli(sub + " --help").out);
      for (std::string line; std::getline(help, line);) lines.push_back(line);
    }
    for (size_t i = 0; i < lines.size(); ++i) {
      std::smatch m;
      if (!std::regex_search(lines[i], m, option)) continue;
      // A long flag name pushes its description to the next line.
      const bool wrapped = i + 1 < lines.size() && lines[i + 1].find_first_not_of(' ') != std::string::npos &&
                           lines[i + 1][lines[i + 1].find_first_not_of(' ')] != '-';
      const std::string line = lines[i] + (wrapped ? lines[i + 1] : "");
      const std::string flag = m[1], type = m[2];
      if (type == "TEXT" || type.rfind("TEXT:", 0) == 0 || flag == "--help") continue;
      if (sub.empty() && flag != "--threads") continue;  // the top level lists only its own flags
      INFO(sub << " " << flag << " (" << type << "): " << line);
      // Ours are INT or NUMBER, with the range in the help; CLI11's own numbers are INT:..., UINT, FLOAT.
      CHECK((type == "INT" || type == "NUMBER"));
      CHECK((line.find("(in [") != std::string::npos || line.find("(in (") != std::string::npos ||
             line.find("(>= ") != std::string::npos));
      ++numeric;
      // Each flag spawns the CLI once per bad value; under the sanitizers (a slow start per process) a
      // flag gets one of the four in turn, so every kind still reaches the parser.
      const std::array<std::string, 4> bads = {"0x10", "nan", "12abc", "99999999999999999999999"};
      for (size_t b = 0; b < bads.size(); ++b) {
        if (ATACOM_TEST_SANITIZED && b != size_t(numeric) % bads.size()) continue;
        const std::string& bad = bads[b];
        const std::string args = sub.empty() ? flag + " " + bad + " filter" : sub + " " + flag + " " + bad;
        const Result r = atacom_cli(args);
        INFO(args << " -> " << r.out);
        CHECK(r.rc == 2);
        CHECK(r.out.find(flag + ": " + bad + " is not ") != std::string::npos);
      }
    }
  }
  CHECK(numeric >= 35);  // the walk saw them (a change of the help format must not make this pass vacuously)
  // Whole decimal text and the range in the message, on the examples of the issue.
  CHECK(atacom_cli("sdf-train --object table --out /nonexistent/x --epochs 0").out.find(
            "--epochs: 0 is not an integer in [1, 100000]") != std::string::npos);
  CHECK(atacom_cli("report /nonexistent --bootstrap-seed -1").out.find(
            "--bootstrap-seed: -1 is not an integer in [0, 2^63 - 1]") != std::string::npos);
  CHECK(atacom_cli("sweep x.json --out /nonexistent/x --jobs 0x10").rc == 2);
  CHECK(atacom_cli("sdf-train --object table --out /nonexistent/x --lr nan").out.find(
            "--lr: nan is not a number in (0, 1]") != std::string::npos);
  CHECK(atacom_cli("sdf-train --object table --out /nonexistent/x --hidden 64,0x10").out.find(
            "--hidden: 0x10 is not an integer in [1, 8192]") != std::string::npos);
}

TEST_CASE("hostile output: a failed write or flush on stdout is an error exit", "[hostile]") {
  if (!fs::exists("/dev/full")) return;  // not Linux: nothing to write to
  for (const std::string& args : std::vector<std::string>{"filter", "rollout --env nav --policy zero --steps 10 --envs 2",
                                                        "--help", "rollout --help"}) {
    const Result r = atacom_cli(args, kValid + "\n", true, "/dev/full");
    INFO(args << " -> " << r.out);
    CHECK(r.rc == 2);
    CHECK((r.out.find("cannot write") != std::string::npos));
  }
}

TEST_CASE("hostile files: a run's next start removes a killed process's temp files, follows no planted link", "[hostile]") {
  const fs::path dir = fs::temp_directory_path() / ("atacom_hostile_run_" + std::to_string(::getpid()));
  const fs::path outside = dir.string() + "_victim";
  fs::remove_all(dir);
  const json cfg = {{"sac", {{"actor", {{"hidden", {8}}}}, {"critic", {{"hidden", {8}}}}, {"batch_size", 8},
                             {"initial_replay", 50}, {"warmup", 50}, {"replay_capacity", 500}}},
                    {"train", {{"env", "pendulum"}, {"steps", 400}, {"eval_every", 200}, {"eval_episodes", 1}}}};
  atacom::TrainOptions o;
  o.out_dir = dir.string();
  o.stop_after = 200;
  atacom::run_training(atacom::resolve_run_config(cfg), o);
  // What a kill -9 mid-write leaves (a pid no process has: above Linux's pid_max of 2^22).
  std::ofstream(dir / "checkpoint.bin.tmp.99999999.Ab12Cd", std::ios::binary) << std::string(1 << 20, 'x');
  std::ofstream(dir / "checkpoint.bin.tmp.99999998", std::ios::binary) << "half";
  std::ofstream(outside) << "keep";
  fs::create_symlink(outside, dir / ("progress.csv.tmp." + std::to_string(::getpid())));  // the old fixed temp name
  o.resume = true;
  o.stop_after = 0;
  atacom::run_training(atacom::resolve_run_config(cfg), o);
  for (const auto& e : fs::directory_iterator(dir))
    CHECK(e.path().filename().string().find(".tmp.") == std::string::npos);
  std::ifstream f(outside);
  std::string s;
  f >> s;
  CHECK(s == "keep");
  fs::remove_all(dir);
  fs::remove(outside);
}

TEST_CASE("hostile config: duplicate keys and a directory as --config are refused by name", "[hostile]") {
  const fs::path cfg = fs::temp_directory_path() / ("atacom_hostile_dup_" + std::to_string(::getpid()) + ".json");
  std::ofstream(cfg) << R"({"train": {"steps": 10, "steps": 20}})";
  Result r = atacom_cli("train --config " + cfg.string() + " --out /nonexistent/x");
  CHECK(r.rc == 2);
  CHECK(r.out.find("duplicate key 'train.steps'") != std::string::npos);
  std::ofstream(cfg) << R"({"velocity_scale": 0.4, "velocity_scale": 0.5})";
  r = atacom_cli("rollout --env table --policy zero --steps 10 --envs 2 --config " + cfg.string());
  CHECK(r.rc == 2);
  CHECK(r.out.find("duplicate key 'velocity_scale'") != std::string::npos);
  r = atacom_cli("rollout --env table --steps 10 --config " + fs::temp_directory_path().string());
  CHECK(r.out.find("is a directory") != std::string::npos);
  CHECK(r.out.find("underflow") == std::string::npos);
  fs::remove(cfg);
}

// Issue 10 item 8: a batch of envs beyond this machine's memory is refused
// with an estimate (measured on two small probe batches, envs/registry.cpp)
// before it is built, never a bare std::bad_alloc or the OOM killer. A nav
// env keeps a physics world (about 190 KB): 2^20 of them need about 200 GB.
TEST_CASE("hostile sizes: --envs beyond this machine's memory is refused with an estimate before allocating",
          "[hostile]") {
  const double have = double(atacom::limits::physical_memory_bytes());
  if (have == 0 || have > 150e9) {
    WARN("this machine's memory (" << have / 1e9 << " GB) holds 2^20 nav envs: nothing to refuse");
    return;
  }
  for (const std::string args : {"rollout --env nav --envs 1048576 --steps 1",
                                 "rollout --env nav --policy la --safety none --envs 1048576 --steps 1",
                                 "train --env nav --algo atacom-sac --envs 1048576 --steps 1048576 --out /nonexistent/x"}) {
    const Result r = atacom_cli(args);
    INFO(args << " -> " << r.out);
    CHECK(r.rc == 2);
    CHECK(r.out.find("1048576 envs of 'nav' (about ") != std::string::npos);
    CHECK(r.out.find("KB each") != std::string::npos);
    CHECK(r.out.find("lower --envs") != std::string::npos);
    CHECK(r.out.find("more than this machine's") != std::string::npos);
    CHECK(r.out.find("bad_alloc") == std::string::npos);
  }
  // Far beyond any machine: the flag's range, by name.
  const Result r = atacom_cli("rollout --env nav --envs 1000000000");
  CHECK(r.rc != 0);
  CHECK(r.out.find("--envs: 1000000000 is not an integer in [1, 2^20]") != std::string::npos);
  // A batch that fits is built as before.
  CHECK(atacom_cli("rollout --env table --policy zero --envs 8192 --steps 8192", "", false).rc == 0);
}

