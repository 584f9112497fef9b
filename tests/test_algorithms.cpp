// The algorithm table and every algorithm end to end: the name -> (source,
// layer) mapping, checkpoint + resume == uninterrupted (bitwise), 1 thread
// == 2 threads, the same summary keys for learners and hand-coded policies,
// and the final and best policy files.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/evaluate.hpp"
#include "atacom/parallel.hpp"
#include "atacom/trainer.hpp"
#include "train/algorithms.hpp"
#include "tests/test_files.hpp"
#include "tests/train_run.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

json summary_without_timing(json s) {
  for (const char* k : {"wall_s", "time_to_target_s", "eval_wall_s", "eval_share", "host"}) s.erase(k);
  return s;
}

// A few hundred nav steps with small networks: updates start at 100 transitions.
json small(const std::string& algo, int64_t steps) {
  json net = {{"hidden", {32, 32}}};
  json sac = {{"actor", net}, {"critic", net}, {"batch_size", 32}, {"initial_replay", 100}, {"warmup", 150},
              {"replay_capacity", 2000}, {"lr_alpha", 1e-3}};
  json cfg = {{"train", {{"env", "nav"}, {"algo", algo}, {"steps", steps}, {"num_envs", 2}, {"eval_every", 200},
                         {"eval_episodes", 2}, {"seed", 3}}},
              {"env", {{"horizon", 100}}}};  // short episodes: quick evaluations, several resets
  const Algorithm& a = find_algorithm(algo);
  if (a.learner == "sac") cfg["sac"] = sac;
  if (a.learner == "adversary") cfg["adversary"] = {{"sac", sac}};
  // PPO: rollouts of 16 batch steps (32 transitions), two minibatches, two epochs
  if (a.learner == "ppo")
    cfg["ppo"] = {{"actor", net}, {"critic", net}, {"rollout_steps", 16}, {"minibatch_size", 16}, {"epochs", 2}};
  return cfg;
}

bool layer_available(SafetyLayer s) {
  try {
    make_env(EnvRequest{"nav", 1, s});
    return true;
  } catch (const std::invalid_argument& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("safelayer") != std::string::npos);  // the clear message wrap_safety gives
    return false;
  }
}

}  // namespace

TEST_CASE("algorithms: every name is an action source under a safety layer", "[algorithms]") {
  const std::vector<std::string> names = algorithm_names();
  for (const char* n : {"sac", "atacom-sac", "safelayer-sac", "ppo", "atacom-ppo", "safelayer-ppo", "la",
                        "la-atacom", "la-safelayer", "random", "random-atacom", "random-safelayer", "zero",
                        "zero-atacom", "zero-safelayer", "attack", "attack-atacom", "attack-safelayer"})
    CHECK(std::find(names.begin(), names.end(), n) != names.end());
  CHECK(find_algorithm("atacom-sac").source == ActionSource::Learner);
  CHECK(find_algorithm("atacom-sac").learner == "sac");
  CHECK(find_algorithm("atacom-sac").safety == SafetyLayer::Atacom);
  CHECK(find_algorithm("safelayer-sac").safety == SafetyLayer::SafeLayer);
  CHECK(find_algorithm("la").source == ActionSource::Attractor);
  CHECK(find_algorithm("la-atacom").safety == SafetyLayer::Atacom);
  CHECK(find_algorithm("attack").learner == "adversary");
  CHECK(find_algorithm("ppo").learner == "ppo");
  CHECK(find_algorithm("atacom-ppo").safety == SafetyLayer::Atacom);
  CHECK(find_algorithm("safelayer-ppo").safety == SafetyLayer::SafeLayer);
  CHECK(find_algorithm("attack").safety == SafetyLayer::None);
  CHECK(algorithm_for(ActionSource::Learner, "adversary", SafetyLayer::Atacom).name == "attack-atacom");
  // each (source, learner, layer) once
  for (const Algorithm& a : algorithms())
    CHECK(algorithm_for(a.source, a.learner, a.safety).name == a.name);
  CHECK_THROWS_WITH(find_algorithm("trpo"), Catch::Contains("la-atacom") && Catch::Contains("trpo"));
  // a learner section that is not the algorithm's is refused
  json cfg = small("la", 100);
  cfg["sac"] = json::object();
  CHECK_THROWS_WITH(resolve_run_config(cfg), Catch::Contains("'sac' does not apply to algo 'la'"));
  cfg = small("attack", 100);
  cfg["sac"] = json::object();
  CHECK_THROWS_WITH(resolve_run_config(cfg), Catch::Contains("adversary"));
  // a re-read config.json (with its host record) resolves to itself
  RunConfig rc = resolve_run_config(small("attack-atacom", 100));
  rc.host = {{"cpu_model", "x"}};
  CHECK(run_config_json(resolve_run_config(run_config_json(rc))) == run_config_json(rc));
}

TEST_CASE("algorithms: the shipped run configs (configs/*.json) still resolve", "[algorithms]") {
  int n = 0;
  for (const auto& f : fs::directory_iterator(fs::path(ATACOM_TEST_DATA_DIR) / ".." / ".." / "configs")) {
    if (f.path().extension() != ".json") continue;
    INFO("config " << f.path());
    CHECK_NOTHROW(resolve_run_config(json::parse(slurp(f.path().string()))));
    ++n;
  }
  CHECK(n >= 5);
}

TEST_CASE("algorithms: every learner checkpoints, resumes bitwise and is identical for 1 and 2 threads", "[algorithms]") {
  for (const char* name : {"sac", "atacom-sac", "safelayer-sac", "ppo", "atacom-ppo", "safelayer-ppo", "attack",
                           "attack-atacom", "attack-safelayer"}) {
    INFO("algo " << name);
    const Algorithm& a = find_algorithm(name);
    if (!layer_available(a.safety)) {
      WARN("algo " << name << ": the " << safety_layer_name(a.safety) << " layer is not in this build; skipped");
      continue;
    }
    const json cfg = small(name, 400);
    const std::string full = tmp_dir(std::string(name) + "_full"), part = tmp_dir(std::string(name) + "_part"),
                      one = tmp_dir(std::string(name) + "_one");
    set_num_threads(2);
    const TrainSummary u = train(cfg, full);
    const TrainSummary s = train(cfg, part, false, 300);  // evaluations at 200 and 400: 300 gets its own checkpoint
    REQUIRE(s.env_steps == 300);
    REQUIRE(!fs::exists(part + "/summary.json"));
    const TrainSummary r = train(cfg, part, true);
    set_num_threads(1);
    const TrainSummary t1 = train(cfg, one);
    set_num_threads(0);
    REQUIRE(u.updates > 0);
    CHECK(r.agent_hash == u.agent_hash);
    CHECK(t1.agent_hash == u.agent_hash);
    CHECK(without_wall(slurp(part + "/progress.csv")) == without_wall(slurp(full + "/progress.csv")));
    CHECK(without_wall(slurp(one + "/progress.csv")) == without_wall(slurp(full + "/progress.csv")));
    CHECK(summary_without_timing(r.summary) == summary_without_timing(u.summary));
    CHECK(summary_without_timing(t1.summary) == summary_without_timing(u.summary));
    CHECK(slurp(part + "/policy_final.bin") == slurp(full + "/policy_final.bin"));
    CHECK(slurp(part + "/policy_best.bin") == slurp(full + "/policy_best.bin"));
    for (const auto& d : {full, part, one}) fs::remove_all(d);
  }
}

TEST_CASE("algorithms: hand-coded policies evaluate only, the same keys as a learner, any thread count", "[algorithms]") {
  const std::string sac_dir = tmp_dir("keys_sac");
  const json sac_sum = train(small("atacom-sac", 200), sac_dir).summary;
  for (const char* name : {"la", "la-atacom", "la-safelayer", "random", "random-atacom", "zero", "zero-atacom"}) {
    INFO("algo " << name);
    if (!layer_available(find_algorithm(name).safety)) continue;
    const std::string d1 = tmp_dir(std::string(name) + "_1"), d2 = tmp_dir(std::string(name) + "_2");
    set_num_threads(1);
    const TrainSummary a = train(small(name, 1000), d1);
    set_num_threads(2);
    const TrainSummary b = train(small(name, 1000), d2);
    set_num_threads(0);
    CHECK(summary_without_timing(a.summary) == summary_without_timing(b.summary));
    CHECK(without_wall(slurp(d1 + "/progress.csv")) == without_wall(slurp(d2 + "/progress.csv")));
    // one evaluation row at env step 0, train_* counters 0, no checkpoint, no policy files
    const json& s = a.summary;
    CHECK(s["env_steps"] == 0);
    CHECK(s["train_episodes"] == 0);
    CHECK(s["train_collisions"] == 0.0);
    CHECK(s["policy_final"].is_null());
    CHECK(s["best"]["env_steps"] == 0);
    CHECK(s["best"]["eval_return_mean"] == s["eval_return_mean"]);
    CHECK(!fs::exists(d1 + "/checkpoint.bin"));
    // every key of the learner's summary but the learner's own
    for (auto it = sac_sum.begin(); it != sac_sum.end(); ++it) {
      if (it.key() == "alpha") continue;
      if (it.key().find("atacom_") != std::string::npos || it.key() == "max_constraint")  // ATACOM's info columns
        if (find_algorithm(name).safety != SafetyLayer::Atacom) continue;
      INFO("key " << it.key());
      CHECK(s.contains(it.key()));
    }
    // the same evaluation start states as the learner's run (same seed): LA-ATACOM != random
    CHECK(s["eval_episodes"] == sac_sum["eval_episodes"]);
    // resuming an evaluation-only run reproduces it
    set_num_threads(2);
    const TrainSummary again = train(small(name, 1000), d1, true);
    set_num_threads(0);
    CHECK(summary_without_timing(again.summary) == summary_without_timing(a.summary));
    fs::remove_all(d1);
    fs::remove_all(d2);
  }
  fs::remove_all(sac_dir);
}

TEST_CASE("algorithms: final and best policy files, named in summary.json, reproduce their evaluations", "[algorithms]") {
  const std::string dir = tmp_dir("policies");
  json cfg = small("atacom-sac", 800);
  const TrainSummary s = train(cfg, dir);
  const json sum = json::parse(slurp(dir + "/summary.json"));
  REQUIRE(sum["policy_final"] == "policy_final.bin");
  REQUIRE(sum["policy_best"] == "policy_best.bin");
  REQUIRE(fs::exists(dir + "/policy_final.bin"));
  REQUIRE(fs::exists(dir + "/policy_best.bin"));
  // best = the row with the largest eval return
  std::istringstream csv(slurp(dir + "/progress.csv"));
  std::string line;
  std::getline(csv, line);
  double best = -1e300;
  int64_t best_steps = -1;
  while (std::getline(csv, line)) {
    std::istringstream ls(line);
    std::string c0, c1, c2, c3;
    std::getline(ls, c0, ',');
    std::getline(ls, c1, ',');
    std::getline(ls, c2, ',');
    std::getline(ls, c3, ',');
    if (std::stod(c3) > best) { best = std::stod(c3); best_steps = std::stoll(c0); }
  }
  CHECK(sum["best"]["env_steps"] == best_steps);
  // Evaluated again, each policy gives its evaluation's numbers exactly.
  RunConfig rc = resolve_run_config(json::parse(slurp(dir + "/config.json")));
  auto env = make_env(EnvRequest{"nav", rc.train.eval_episodes, SafetyLayer::Atacom, rc.env});
  auto fin = TrainedPolicy::load(dir, RunPolicy::Final);
  auto bst = TrainedPolicy::load(dir, RunPolicy::Best);
  CHECK(fin->manifest()["env_steps"] == 800);
  CHECK(bst->manifest()["env_steps"] == best_steps);
  const EvalResult ef = evaluate(*env, *fin, rc.train.eval_episodes, uint64_t(rc.train.seed), true);
  const EvalResult eb = evaluate(*env, *bst, rc.train.eval_episodes, uint64_t(rc.train.seed), true);
  CHECK(ef.return_mean == sum["eval_return_mean"].get<double>());
  CHECK(eb.return_mean == sum["best"]["eval_return_mean"].get<double>());
  CHECK(fin->safety() == SafetyLayer::Atacom);
  // host record in both files
  const json conf = json::parse(slurp(dir + "/config.json"));
  for (const json* j : {&conf["host"], &sum["host"]})
    for (const char* k : {"cpu_model", "cpu_isa_flags", "compiler", "build_flags", "build_type", "git_describe"})
      CHECK(j->contains(k));
  // a policy file of another run is refused
  const std::string other = tmp_dir("policies_other");
  train(small("sac", 200), other);
  fs::copy_file(other + "/policy_final.bin", dir + "/policy_final.bin", fs::copy_options::overwrite_existing);
  CHECK_NOTHROW(TrainedPolicy::load(dir));  // same kind, env and dims: loads (the manifest names its run)
  fs::copy_file(dir + "/config.json", other + "/config.json", fs::copy_options::overwrite_existing);
  fs::remove_all(other);
  // an evaluation-only run has no policy
  const std::string la = tmp_dir("policies_la");
  train(small("la", 100), la);
  CHECK_THROWS_WITH(TrainedPolicy::load(la), Catch::Contains("learns nothing"));
  fs::remove_all(la);
  fs::remove_all(dir);
}
