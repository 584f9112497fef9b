// A run directory against hostile or broken states (issue 10 items 2, 5 in
// part, 6, 7): resume refuses what it cannot continue, checkpoint counters
// are validated against the config, progress.csv is replaced rather than
// written through, and every subcommand takes --config FILE and rejects
// flags that do not apply.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"
#include "run_dir_compare.hpp"
#include "train/checkpoint.hpp"
#include "tests/test_files.hpp"
#include "tests/train_run.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

json small_sac_run(int64_t steps) {
  return {{"sac", {{"actor", {{"hidden", {16, 16}}}}, {"critic", {{"hidden", {16, 16}}}}, {"batch_size", 16},
                   {"initial_replay", 100}, {"warmup", 100}, {"replay_capacity", 2000}}},
          {"train", {{"env", "pendulum"}, {"steps", steps}, {"eval_every", 200}, {"eval_episodes", 2}, {"seed", 1}}}};
}

int cli(const std::string& args, const std::string& log) {
  return std::system((std::string(ATACOM_ATACOM_EXE) + " " + args + " > " + log + " 2>&1").c_str());
}

// Rewrites the checkpoint with one 8-byte field of its payload replaced, with a valid checksum.
template <class T>
void patch_checkpoint(const std::string& path, size_t offset, T value) {
  Checkpoint ck = read_checkpoint(path);
  REQUIRE(offset + sizeof(T) <= ck.payload.size());
  std::memcpy(ck.payload.data() + offset, &value, sizeof(T));
  write_checkpoint_atomic(path, ck);
}
uint64_t u64_at(const std::string& s, size_t off) {
  uint64_t v;
  std::memcpy(&v, s.data() + off, 8);
  return v;
}

}  // namespace

TEST_CASE("run files: --resume refuses a missing directory, one without config.json, a lost checkpoint", "[run_files]") {
  const std::string dir = tmp_dir("resume"), log = dir + ".log";
  CHECK_THROWS_WITH(train(small_sac_run(400), dir, true), Catch::Contains("does not exist"));
  fs::create_directories(dir);
  CHECK_THROWS_WITH(train(small_sac_run(400), dir, true), Catch::Contains("no config.json"));
  // The command line too: before this change it trained the defaults (pendulum, 100k steps) silently.
  CHECK(cli("train --resume --out " + dir, log) != 0);
  CHECK(slurp(log).find("config.json") != std::string::npos);
  CHECK(fs::is_empty(dir));
  CHECK(cli("train --resume --out " + dir + "_missing", log) != 0);
  CHECK(slurp(log).find("does not exist") != std::string::npos);
  fs::remove_all(dir);
  // A run with evaluations whose checkpoint.bin was deleted cannot continue bitwise: refused.
  train(small_sac_run(600), dir, false, 400);
  fs::remove(dir + "/checkpoint.bin");
  CHECK_THROWS_WITH(train(small_sac_run(600), dir, true), Catch::Contains("checkpoint.bin is missing") &&
                                                         Catch::Contains("2 evaluation rows"));
  // Killed before its first checkpoint (config.json and the header only): restarts, and says so.
  fs::remove_all(dir);
  train(small_sac_run(600), dir, false, 100);
  fs::remove(dir + "/checkpoint.bin");
  std::ostringstream msg;
  const TrainSummary s = train(small_sac_run(600), dir, true, 0, &msg);
  CHECK(msg.str().find("starting the run at step 0") != std::string::npos);
  CHECK(s.env_steps == 600);
  const std::string fresh = tmp_dir("resume_fresh");
  CHECK(train(small_sac_run(600), fresh).agent_hash == s.agent_hash);
  fs::remove_all(fresh);
  fs::remove_all(dir);
  fs::remove(log);
}

TEST_CASE("run files: impossible checkpoint counters are refused by name, files left alone", "[run_files]") {
  const std::string dir = tmp_dir("counters");
  train(small_sac_run(600), dir, false, 300);
  const std::string ck = dir + "/checkpoint.bin", good = slurp(ck), csv = slurp(dir + "/progress.csv");
  const std::string payload = read_checkpoint(ck).payload;
  // payload: tag (4) | env_steps next_eval next_ckpt train_episodes train_terminations train_violations
  //          train_max_constraint wall_s recent_returns recent_return_sum last_train_return progress_rows
  //          eval_wall_s target_env_steps target_updates target_wall_s target_train_cost (8 each)
  struct Case { size_t off; int64_t value; const char* name; };
  const size_t learner = [&] {
    size_t off = 4 + 17 * 8;
    off += 8 + 8 * u64_at(payload, off);  // train info sums
    off += 8 + u64_at(payload, off);      // best evaluation
    return off + 4 + 4;                   // "LRNR", "SACL": the update budget
  }();
  for (const Case& c : {Case{12, INT64_MIN, "next_eval"}, Case{4, 1000000000000000000, "env_steps"},
                        Case{4 + 11 * 8, 0, "progress_rows"}, Case{4 + 11 * 8, 1000, "progress_rows"},
                        Case{4 + 3 * 8, -5, "train_episodes"}, Case{4 + 13 * 8, 7, "target_env_steps = 7"},
                        Case{4 + 14 * 8, 5, "target_updates"}}) {
    INFO("field " << c.name);
    patch_checkpoint(ck, c.off, c.value);
    CHECK_THROWS_WITH(train(small_sac_run(600), dir, true), Catch::Contains(c.name));
    CHECK(slurp(dir + "/progress.csv") == csv);  // the header and rows survive
    std::ofstream(ck, std::ios::binary | std::ios::trunc) << good;
  }
  patch_checkpoint(ck, learner, 1e18);
  CHECK_THROWS_WITH(train(small_sac_run(600), dir, true), Catch::Contains("budget"));
  std::ofstream(ck, std::ios::binary | std::ios::trunc) << good;
  CHECK(train(small_sac_run(600), dir, true).env_steps == 600);  // the untouched checkpoint still resumes
  fs::remove_all(dir);
}

TEST_CASE("run files: a budget below what is done is refused, config.json and summary.json stay consistent", "[run_files]") {
  const std::string dir = tmp_dir("budget"), log = dir + ".log";
  train(small_sac_run(600), dir);
  CHECK_THROWS_WITH(train(small_sac_run(200), dir, true), Catch::Contains("below the 600 env steps"));
  CHECK(cli("train --resume --steps 100 --out " + dir, log) != 0);
  CHECK(slurp(log).find("below") != std::string::npos);
  CHECK(json::parse(slurp(dir + "/config.json"))["train"]["steps"] == 600);
  CHECK(json::parse(slurp(dir + "/summary.json"))["env_steps"] == 600);
  // the same budget again: a finished run, re-evaluated, unchanged
  CHECK(cli("train --resume --out " + dir, log) == 0);
  CHECK(json::parse(slurp(dir + "/summary.json"))["env_steps"] == 600);
  fs::remove_all(dir);
  fs::remove(log);
}

TEST_CASE("run files: a symlinked progress.csv is replaced on resume, never written through", "[run_files]") {
  const std::string dir = tmp_dir("symlink"), outside = dir + "_outside.csv";
  train(small_sac_run(600), dir, false, 300);
  const std::string rows = slurp(dir + "/progress.csv");
  std::ofstream(outside, std::ios::binary) << rows;
  fs::remove(dir + "/progress.csv");
  fs::create_symlink(outside, dir + "/progress.csv");
  train(small_sac_run(600), dir, true);
  CHECK(slurp(outside) == rows);  // before this change the resume truncated and appended through the link
  CHECK(!fs::is_symlink(dir + "/progress.csv"));
  CHECK(slurp(dir + "/progress.csv").size() > rows.size());
  fs::remove(outside);
  fs::remove_all(dir);
}

TEST_CASE("run files: --config is a file for every subcommand, flags that do not apply are rejected", "[run_files]") {
  const std::string dir = tmp_dir("flags"), log = dir + ".log", cfg = dir + ".json";
  std::ofstream(cfg) << R"({"velocity_scale": 0.4})";
  // shelf-real: a file path (before this change: inline JSON only)
  CHECK(cli("shelf-real --policy zero --trials 2 --config " + cfg, log) == 0);
  CHECK(json::parse(slurp(log))["targets"].size() == 2);
  // every layer: the policy through SafeLayer or CBF as well as ATACOM or none
  for (const char* layer : {"none", "atacom", "safelayer", "cbf"}) {
    INFO(layer);
    CHECK(cli(std::string("shelf-real --policy la --trials 2 --safety ") + layer, log) == 0);
    const json sr = json::parse(slurp(log));
    CHECK(sr["safety"] == layer);
    CHECK(sr["protocol"]["safety"] == layer);
    CHECK(sr["protocol"]["atacom"] == (std::string(layer) == "atacom"));
    CHECK(sr["protocol"].contains("cbf_gamma") == (std::string(layer) == "cbf"));
  }
  CHECK(cli("shelf-real --policy la --trials 2 --safety qp", log) != 0);
  CHECK(slurp(log).find("--safety: qp not in {none,atacom,safelayer,cbf}") != std::string::npos);
  CHECK(cli("shelf-real --policy zero --trials 2 --config '{}'", log) != 0);
  CHECK(slurp(log).find("cannot read config file") != std::string::npos);
  CHECK(cli("shelf-real --policy zero --trials 2 --config " + fs::temp_directory_path().string(), log) != 0);
  CHECK(slurp(log).find("is a directory") != std::string::npos);
  // --run without --policy trained: rejected, not echoed
  CHECK(cli("shelf-real --policy la --trials 2 --run " + dir, log) != 0);
  CHECK(slurp(log).find("--run applies to --policy trained only") != std::string::npos);
  CHECK(cli("rollout --env nav --policy random --steps 100 --envs 2 --run " + dir, log) != 0);
  CHECK(slurp(log).find("--run applies to --policy trained only") != std::string::npos);
  CHECK(cli("rollout --env nav --policy zero --steps 100 --envs 2 --which best", log) != 0);
  CHECK(cli("rollout --env nav --atacom on --safety none --steps 100 --envs 2", log) != 0);
  CHECK(slurp(log).find("contradicts") != std::string::npos);
  // a trained policy: the run's env and layer; env overrides do not apply
  json run = small_sac_run(300);
  run["train"]["env"] = "nav";
  run["train"]["algo"] = "atacom-sac";
  train(run, dir);
  CHECK(cli("rollout --policy trained --run " + dir + " --steps 200 --envs 2", log) == 0);
  const json r = json::parse(slurp(log));
  CHECK(r["env"] == "nav");
  CHECK(r["safety"] == "atacom");
  CHECK(r["run_algo"] == "atacom-sac");
  for (const char* k : {"steps", "episodes", "collisions", "violations", "max_constraint", "per_s"}) CHECK(r.contains(k));
  CHECK(cli("rollout --policy trained --run " + dir + " --steps 200 --envs 2 --which best", log) == 0);
  CHECK(cli("rollout --policy trained --run " + dir + " --steps 200 --config " + cfg, log) != 0);
  CHECK(slurp(log).find("does not apply") != std::string::npos);
  CHECK(cli("rollout --policy trained --run " + dir + " --env table --steps 200", log) != 0);
  CHECK(slurp(log).find("differs") != std::string::npos);
  CHECK(cli("shelf-real --policy trained --run " + dir + " --trials 2", log) != 0);
  CHECK(slurp(log).find("not shelf") != std::string::npos);
  fs::remove_all(dir);
  fs::remove(log);
  fs::remove(cfg);
}

// Issue 14 section 1 for one run: killed (SIGKILL) before each of its file
// writes in turn (src/core/fs_util.hpp: the n-th write's temp file is written,
// not renamed: the files of a kill anywhere after write n - 1), the same
// command again (with --resume once config.json is there) ends with files
// identical to an uninterrupted run's, policy_best and policy_final included.
TEST_CASE("run files: killed with SIGKILL before any file write, train --resume ends with the uninterrupted files",
          "[run_files]") {
  const std::string ref = tmp_dir("kill_ref"), dir = tmp_dir("kill"), cfg = tmp_dir("kill_cfg.json"),
                    log = tmp_dir("kill.log");
  std::ofstream(cfg) << small_sac_run(600).dump();
  const std::string first = "--threads 1 train --config " + cfg + " --out ";
  REQUIRE(cli(first + ref, log) == 0);
  const auto want = run_dir_compare::files(ref, ref);
  REQUIRE(want.count("policy_best.bin") == 1);
  REQUIRE(want.count("policy_final.bin") == 1);
  int kills = 0;
  for (int n = 1;; ++n) {
    INFO("killed at write " << n);
    fs::remove_all(dir);
    ::setenv("ATACOM_TEST_KILL_AT_WRITE", std::to_string(n).c_str(), 1);
    const int code = cli(first + dir, log);
    ::unsetenv("ATACOM_TEST_KILL_AT_WRITE");
    if (code == 0) break;  // n is past the run's last write
    ++kills;
    const bool has_config = fs::exists(dir + "/config.json");
    REQUIRE(cli(has_config ? "--threads 1 train --resume --out " + dir : first + dir, log) == 0);
    run_dir_compare::require_same(want, run_dir_compare::files(dir, dir));
    REQUIRE(n < 100);
  }
  CHECK(kills >= 12);  // config, header, 3 evaluations x (row, SVG, checkpoint, manifest, best policy), final, summary
  for (const auto& p : {ref, dir, cfg, log}) fs::remove_all(p);
}

