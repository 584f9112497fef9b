#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "build_kind.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/trainer.hpp"
#include "src/core/binary_io.hpp"
#include "train/checkpoint.hpp"
#include "tests/test_files.hpp"
#include "tests/train_run.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A small, quick pendulum run: updates start at 200 transitions.
json small_run(int64_t steps) {
  return {{"sac", {{"actor", {{"hidden", {32, 32}}}}, {"critic", {{"hidden", {32, 32}}}}, {"batch_size", 32},
                   {"initial_replay", 200}, {"warmup", 300}, {"gamma", 0.99}, {"lr_alpha", 1e-3},
                   {"replay_capacity", 5000}}},
          {"train", {{"env", "pendulum"}, {"steps", steps}, {"eval_every", 300}, {"eval_episodes", 3}, {"seed", 7}}}};
}

// progress.csv without the wall_s column (the only one that may differ between runs).
std::string progress_without_wall(const std::string& dir) {
  std::istringstream in(slurp(dir + "/progress.csv"));
  std::string line, out;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string cell;
    int k = 0;
    while (std::getline(ls, cell, ',')) {
      if (k++ != 2) out += cell + ",";
    }
    out += "\n";
  }
  return out;
}

}  // namespace

TEST_CASE("trainer: run directory outputs", "[trainer]") {
  const std::string dir = tmp_dir("outputs");
  json cfg = small_run(600);
  cfg["train"]["num_envs"] = 2;
  const auto s = train(cfg, dir);
  REQUIRE(s.env_steps == 600);
  REQUIRE(s.updates == 600 - 200);
  // config.json is the full resolved config and re-resolves to itself
  const json saved = json::parse(slurp(dir + "/config.json"));
  REQUIRE(saved["sac"]["tau"] == 1e-3);
  REQUIRE(saved["env"]["max_torque"] == 2.0);
  REQUIRE(atacom::run_config_json(atacom::resolve_run_config(saved)) == saved);
  // progress.csv: header + one row per evaluation (300, 600)
  std::istringstream csv(slurp(dir + "/progress.csv"));
  std::string header, row;
  std::getline(csv, header);
  std::string expect;
  const auto spec = atacom::make_env(atacom::EnvRequest{"pendulum", 1}).get()->spec();
  for (const auto& c : atacom::progress_columns(spec, {"alpha", "actor_loss", "critic_loss", "alpha_loss", "entropy",
                                                       "q_mean"}))
    expect += (expect.empty() ? "" : ",") + c;
  REQUIRE(header == expect);
  REQUIRE(header.rfind("env_steps,updates,wall_s,eval_return_mean,eval_return_std,train_episode_return,alpha,actor_loss,"
                       "critic_loss,alpha_loss,entropy,q_mean,abs_theta,nonfinite_action,early_terminations,"
                       "avg_episode_steps,violations,", 0) == 0);
  int rows = 0;
  while (std::getline(csv, row)) ++rows;
  REQUIRE(rows == 2);
  const json sum = json::parse(slurp(dir + "/summary.json"));
  for (const char* k : {"eval_return_mean", "eval_return_std", "env_steps", "updates", "wall_s", "abs_theta",
                        "nonfinite_action", "early_terminations", "avg_episode_steps", "train_episodes",
                        "train_terminations", "train_nonfinite_action"})
    REQUIRE(sum.contains(k));
  REQUIRE(sum["train_episodes"] == 2);  // 300 steps per env: one finished episode each
  REQUIRE(sum["avg_episode_steps"] == 200.0);
  REQUIRE(sum["train_avg_episode_steps"] == 200.0);  // pendulum never terminates: every episode is the horizon
  REQUIRE(slurp(dir + "/progress.svg").rfind("<svg", 0) == 0);
  REQUIRE(json::parse(slurp(dir + "/checkpoint.json"))["env_steps"] == 600);
  fs::remove_all(dir);
}

// The paper's "average episode steps over training" from the finished
// episodes: whole steps over episodes, at most the horizon, below it once an
// episode ended early, and the steps of unfinished episodes left out.
TEST_CASE("trainer: train_avg_episode_steps is the mean length of the finished training episodes", "[trainer]") {
  const std::string dir = tmp_dir("avg_steps");
  json cfg = small_run(4000);
  cfg["train"]["env"] = "table";
  cfg["train"]["num_envs"] = 4;
  cfg["train"]["eval_every"] = 2000;
  cfg["train"]["eval_episodes"] = 1;
  const json s = train(cfg, dir).summary;
  const int horizon = atacom::make_env(atacom::EnvRequest{"table", 1})->spec().horizon;
  const double avg = s["train_avg_episode_steps"].get<double>(), n = s["train_episodes"].get<double>();
  INFO("avg " << avg << " over " << n << " episodes, " << s["train_terminations"] << " early, horizon " << horizon);
  REQUIRE(n >= 4);
  const double total = avg * n;
  REQUIRE(std::abs(total - std::round(total)) < 1e-6 * total);
  REQUIRE(avg <= horizon);
  if (s["train_terminations"].get<int>() > 0) REQUIRE(avg < horizon);
  REQUIRE(total <= 4000);
  REQUIRE(total >= 4000 - 4.0 * horizon);
  REQUIRE(s["avg_episode_steps"].is_number());  // the final evaluation's, kept beside it
  fs::remove_all(dir);
}

TEST_CASE("trainer: updates per env step below and above one, N envs", "[trainer]") {
  for (double ratio : {0.5, 2.0}) {
    json cfg = small_run(600);
    cfg["train"]["num_envs"] = 3;
    cfg["train"]["eval_every"] = 600;
    cfg["sac"]["updates_per_step"] = ratio;
    cfg["sac"]["obs_norm"] = false;
    const std::string dir = tmp_dir("ratio");
    const auto s = train(cfg, dir);
    // expected: the budget grows by ratio * N per batch step; an update runs
    // when the replay holds more than initial_replay (200) transitions
    int64_t expect = 0;
    double budget = 0;
    for (int k = 1; k <= 200; ++k) {
      budget += ratio * 3;
      while (budget >= 1.0) {
        budget -= 1.0;
        expect += 3 * k > 200;
      }
    }
    REQUIRE(s.updates == expect);
    REQUIRE(s.env_steps == 600);
    fs::remove_all(dir);
  }
}

TEST_CASE("trainer: bitwise identical with 1 and 2 threads", "[trainer]") {
  // Shapes above one GEMM tile (256 rows x 128 columns) so the partition and
  // the TBB path are exercised.
  const int updates = sanitizer_scaled(150, 5);  // a multiple of num_envs (3)
  json cfg = small_run(300 + updates);
  cfg["sac"]["actor"]["hidden"] = {256, 160};
  cfg["sac"]["critic"]["hidden"] = {256, 160};
  cfg["sac"]["batch_size"] = 300;
  cfg["sac"]["initial_replay"] = 300;
  cfg["train"]["num_envs"] = 3;
  const std::string d1 = tmp_dir("threads1"), d2 = tmp_dir("threads2");
  atacom::set_num_threads(1);
  const auto a = train(cfg, d1);
  atacom::set_num_threads(2);
  const auto b = train(cfg, d2);
  atacom::set_num_threads(0);
  REQUIRE(a.updates == updates);
  REQUIRE(a.agent_hash == b.agent_hash);
  REQUIRE(progress_without_wall(d1) == progress_without_wall(d2));
  fs::remove_all(d1);
  fs::remove_all(d2);
}

TEST_CASE("trainer: killed after a checkpoint and resumed == uninterrupted (short)", "[trainer]") {
  const json cfg = small_run(700);
  const std::string full = tmp_dir("full"), part = tmp_dir("part");
  const auto u = train(cfg, full);
  const auto stopped = train(cfg, part, false, 450);  // not an eval boundary: its own checkpoint
  REQUIRE(stopped.env_steps == 450);
  REQUIRE(!fs::exists(part + "/summary.json"));
  const auto r = train(cfg, part, true);
  REQUIRE(r.env_steps == 700);
  REQUIRE(r.agent_hash == u.agent_hash);
  REQUIRE(progress_without_wall(part) == progress_without_wall(full));
  REQUIRE(r.final_eval.return_mean == u.final_eval.return_mean);
  fs::remove_all(full);
  fs::remove_all(part);
}

TEST_CASE("trainer: 2k steps, checkpoint, 1k more == uninterrupted 3k, bitwise", "[trainer][slow]") {
  json cfg = small_run(3000);
  cfg["train"]["eval_every"] = 1000;
  const std::string full = tmp_dir("full3k"), part = tmp_dir("part2k");
  const auto u = train(cfg, full);
  json first = cfg;
  first["train"]["steps"] = 2000;
  train(first, part);
  // resume with a larger budget, as `atacom train --resume --steps 3000` does
  atacom::RunConfig rc = atacom::resolve_run_config(json::parse(slurp(part + "/config.json")));
  rc.train.steps = 3000;
  atacom::TrainOptions o;
  o.out_dir = part;
  o.resume = true;
  const auto r = atacom::run_training(rc, o);
  REQUIRE(r.agent_hash == u.agent_hash);
  REQUIRE(r.updates == u.updates);
  REQUIRE(progress_without_wall(part) == progress_without_wall(full));
  fs::remove_all(full);
  fs::remove_all(part);
}

TEST_CASE("trainer: corrupted or truncated checkpoints are rejected on resume", "[trainer]") {
  const json cfg = small_run(400);
  const std::string dir = tmp_dir("corrupt");
  train(cfg, dir, false, 300);
  const std::string good = slurp(dir + "/checkpoint.bin");
  {
    std::ofstream f(dir + "/checkpoint.bin", std::ios::binary | std::ios::trunc);
    f << good.substr(0, good.size() / 3);
  }
  REQUIRE_THROWS_WITH(train(cfg, dir, true), Catch::Contains("truncated"));
  {
    std::string bad = good;
    bad[bad.size() / 2] ^= 0x01;
    std::ofstream f(dir + "/checkpoint.bin", std::ios::binary | std::ios::trunc);
    f << bad;
  }
  REQUIRE_THROWS_WITH(train(cfg, dir, true), Catch::Contains("checksum"));
  // a checkpoint from another config is refused too
  {
    std::ofstream f(dir + "/checkpoint.bin", std::ios::binary | std::ios::trunc);
    f << good;
  }
  json other = cfg;
  other["sac"]["tau"] = 0.5;
  REQUIRE_THROWS_WITH(train(other, dir, true), Catch::Contains("different config"));
  fs::remove_all(dir);
}

TEST_CASE("trainer: bad configs and unusable directories fail before any work", "[trainer]") {
  const std::string dir = tmp_dir("errors");
  json cfg = small_run(100);
  cfg["sac"]["lr_actorr"] = 1.0;
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("sac.lr_actorr"));
  cfg = small_run(100);
  cfg["trian"] = json::object();
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("config.trian"));
  cfg = small_run(100);
  cfg["train"]["algo"] = "ppo";
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("algo"));
  cfg = small_run(100);
  cfg["train"]["env"] = "nowhere";
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("unknown env"));
  cfg = small_run(100);
  cfg["env"] = {{"gravity", 9.81}};
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("gravity"));
  cfg = small_run(100);
  cfg["train"]["steps"] = 0;
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(cfg), Catch::Contains("steps"));
  // ATACOM needs a constraint model: refused before the directory is made
  cfg = small_run(100);
  cfg["train"]["algo"] = "atacom-sac";
  REQUIRE_THROWS_WITH(train(cfg, dir), Catch::Contains("ATACOM"));
  REQUIRE(!fs::exists(dir));
  // a non-empty directory without --resume
  fs::create_directories(dir);
  std::ofstream(dir + "/something") << "x";
  REQUIRE_THROWS_WITH(train(small_run(100), dir), Catch::Contains("--resume"));
  fs::remove_all(dir);
}

TEST_CASE("trainer: learning curve SVG", "[trainer]") {
  const std::string svg = atacom::learning_curve_svg("a <b>", {1000, 2000, 3000}, {-1000, -500, -150}, {50, 40, 30});
  REQUIRE(svg.rfind("<svg", 0) == 0);
  REQUIRE(svg.find("polyline") != std::string::npos);
  REQUIRE(svg.find("a &lt;b&gt;") != std::string::npos);
  REQUIRE(svg.find("</svg>") != std::string::npos);
}

TEST_CASE("trainer: atacom train command line", "[trainer]") {
  const std::string exe = ATACOM_ATACOM_EXE;
  const std::string dir = tmp_dir("cli"), log = dir + ".log", cfgp = dir + ".json";
  std::ofstream(cfgp) << small_run(400).dump();
  auto run = [&](const std::string& args) {
    return std::system((exe + " " + args + " > " + log + " 2>&1").c_str());
  };
  REQUIRE(run("train --env pendulum --algo atacom-sac --steps 10 --out " + dir) != 0);
  REQUIRE(slurp(log).find("ATACOM") != std::string::npos);
  REQUIRE(!fs::exists(dir));
  std::ofstream(cfgp + ".bad") << R"({"sac": {"bach_size": 3}})";
  REQUIRE(run("train --env pendulum --algo sac --steps 10 --config " + cfgp + ".bad --out " + dir) != 0);
  REQUIRE(slurp(log).find("sac.bach_size") != std::string::npos);
  REQUIRE(run("--threads 1 train --config " + cfgp + " --seed 3 --steps 300 --out " + dir) == 0);
  REQUIRE(json::parse(slurp(dir + "/config.json"))["train"]["seed"] == 3);
  REQUIRE(run("train --config " + cfgp + " --out " + dir) != 0);
  REQUIRE(slurp(log).find("not empty") != std::string::npos);
  REQUIRE(run("train --resume --steps 400 --out " + dir) == 0);
  REQUIRE(json::parse(slurp(dir + "/summary.json"))["env_steps"] == 400);
  REQUIRE(run("train --resume --seed 4 --out " + dir) != 0);
  REQUIRE(slurp(log).find("--seed differs") != std::string::npos);
  fs::remove_all(dir);
  fs::remove(log);
  fs::remove(cfgp);
  fs::remove(cfgp + ".bad");
}

TEST_CASE("trainer: atacom-sac through SafeEnv on nav, resumed bitwise", "[trainer]") {
  // The generic path end to end: an env with constraints, wrapped in ATACOM
  // by the registry, its info columns in progress.csv and summary.json.
  json cfg = small_run(800);
  cfg["train"]["env"] = "nav";
  cfg["train"]["algo"] = "atacom-sac";
  cfg["train"]["num_envs"] = 4;
  cfg["train"]["eval_every"] = 400;
  cfg["train"]["eval_episodes"] = 2;
  const std::string full = tmp_dir("nav_full"), part = tmp_dir("nav_part");
  const auto u = train(cfg, full);
  train(cfg, part, false, 400);
  const auto r = train(cfg, part, true);
  REQUIRE(r.agent_hash == u.agent_hash);
  REQUIRE(progress_without_wall(part) == progress_without_wall(full));
  const json sum = json::parse(slurp(full + "/summary.json"));
  REQUIRE(sum["algo"] == "atacom-sac");
  REQUIRE(sum.contains("max_constraint"));
  REQUIRE(sum.contains("train_collision"));
  fs::remove_all(full);
  fs::remove_all(part);
}

TEST_CASE("trainer: a run's policy loads from its directory and acts like the trained agent", "[trainer]") {
  const std::string dir = tmp_dir("policy");
  const auto s = train(small_run(600), dir);
  const auto policy = atacom::TrainedPolicy::load(dir);
  REQUIRE(policy->obs_dim() == 3);
  REQUIRE(policy->act_dim() == 1);
  // Deterministic: the same observations give the same actions, inside [-1, 1].
  const std::vector<float> obs = {1.0f, 0.0f, 0.5f, 0.0f, 1.0f, -2.0f, -1.0f, 0.0f, 7.0f};
  std::vector<double> a1(3), a2(3);
  policy->act(obs.data(), 3, a1.data());
  policy->act(obs.data(), 3, a2.data());
  CHECK(a1 == a2);
  for (double v : a1) CHECK(std::abs(v) <= 1.0);
  // A second load gives the same agent.
  std::vector<double> a3(3);
  atacom::TrainedPolicy::load(dir)->act(obs.data(), 3, a3.data());
  CHECK(a1 == a3);
  CHECK_THROWS_WITH(atacom::TrainedPolicy::load(dir + "_missing"), Catch::Contains("config.json"));
  // A policy file of container version 4 (the policy bytes unchanged since;
  // checksum recomputed) still loads and acts the same; version 3 does not.
  const std::string good = slurp(dir + "/policy_final.bin");
  for (const uint32_t v : {atacom::kOldestPolicyVersion, atacom::kOldestPolicyVersion - 1}) {
    std::string old_file = good.substr(0, good.size() - 8);
    old_file[8] = char(v);
    const uint64_t h = atacom::bin::fnv1a(old_file.data(), old_file.size());
    old_file.append(reinterpret_cast<const char*>(&h), sizeof h);
    std::ofstream(dir + "/policy_final.bin", std::ios::binary | std::ios::trunc) << old_file;
    if (v == atacom::kOldestPolicyVersion) {
      std::vector<double> a4(3);
      atacom::TrainedPolicy::load(dir)->act(obs.data(), 3, a4.data());
      CHECK(a1 == a4);
    } else {
      CHECK_THROWS_WITH(atacom::TrainedPolicy::load(dir), Catch::Contains("format version " + std::to_string(v)));
    }
  }
  std::ofstream(dir + "/policy_final.bin", std::ios::trunc) << "garbage";  // the policy lives here, not in the checkpoint
  CHECK_THROWS(atacom::TrainedPolicy::load(dir));
  fs::remove_all(dir);
}

TEST_CASE("trainer: the ETA waits for the warm-up, then counts from the first update", "[trainer]") {
  const std::string dir = tmp_dir("eta");
  json cfg = small_run(600);  // updates start after 200 transitions
  cfg["train"]["eval_every"] = 100;
  std::ostringstream log;
  atacom::TrainOptions o;
  o.out_dir = dir;
  o.log = &log;  // not a terminal: one line per evaluation
  atacom::run_training(atacom::resolve_run_config(cfg), o);
  std::istringstream lines(log.str());
  std::vector<std::string> l;
  for (std::string s; std::getline(lines, s);) l.push_back(s);
  REQUIRE(l.size() == 6);
  CHECK(l[0].find(" 100/600 steps") != std::string::npos);
  CHECK(l[0].find("ETA after warm-up") != std::string::npos);  // no rate yet: the fast warm-up would mislead
  CHECK(l[1].find("ETA after warm-up") != std::string::npos);  // 200 steps: the first update is the next step
  for (size_t i = 2; i < l.size(); ++i) {
    INFO(l[i]);
    CHECK(std::regex_search(l[i], std::regex("ETA [0-9]+(s|m[0-9]{2}s)")));
  }
  fs::remove_all(dir);
}
