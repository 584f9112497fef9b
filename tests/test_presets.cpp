// Learner presets (train/presets.hpp) and the safety-layer table: the paper
// preset resolves every cell exactly as the per-env defaults did before
// presets existed (tests/data/paper_preset_golden.json, written by 1fe7f3d),
// every shipped preset names real envs and algorithms and resolves, wildcard
// sections reach only the cells that use them, and a layer's section is
// refused where its layer does not run.
#include <catch2/catch.hpp>

#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/learner.hpp"
#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"
#include "train/algorithms.hpp"
#include "train/presets.hpp"

using nlohmann::json;
using namespace atacom;

namespace {
json read_json(const std::string& path) {
  std::ifstream f(path);
  REQUIRE(f.good());
  return json::parse(f);
}
}  // namespace

TEST_CASE("presets: the paper preset resolves every learner cell as before presets existed", "[presets]") {
  // Each golden entry holds the learner section and the train section of the
  // config.json that `atacom train --env E --algo A --steps 1
  // --eval-episodes 1` wrote at 1fe7f3d.
  const json golden = read_json(std::string(ATACOM_TEST_DATA_DIR) + "/paper_preset_golden.json");
  REQUIRE(golden.size() >= 20);
  for (auto it = golden.begin(); it != golden.end(); ++it) {
    const std::string key = it.key();
    const std::string env = key.substr(0, key.find('/')), algo = key.substr(key.find('/') + 1);
    INFO(key);
    // (written with --steps 1 --eval-episodes 1; every other key from the defaults)
    const json& gt = it.value().at("train");
    json now = run_config_json(resolve_run_config(
        {{"train", {{"env", env}, {"algo", algo}, {"steps", gt.at("steps")}, {"eval_episodes", gt.at("eval_episodes")},
                    // eval_every's default now depends on the budget (1000 under 50k steps): given as then
                    {"eval_every", gt.at("eval_every")}}}}));
    CHECK(now["train"]["preset"] == "paper");
    now["train"].erase("preset");
    for (auto s = it.value().begin(); s != it.value().end(); ++s) {
      if (s.key() != "train") {
        CHECK(now[s.key()] == s.value());
        continue;
      }
      for (auto k = s.value().begin(); k != s.value().end(); ++k) CHECK(now["train"][k.key()] == k.value());  // keys added since (stop_at_target) aside
    }
  }
}

TEST_CASE("presets: every shipped preset names real cells, explains itself and resolves", "[presets]") {
  const std::vector<std::string> envs = env_names(), algos = algorithm_names();
  auto known = [](const std::vector<std::string>& v, const std::string& s) {
    return s == "*" || std::find(v.begin(), v.end(), s) != v.end();
  };
  std::set<std::string> names;
  for (const Preset& p : presets()) {
    names.insert(p.name);
    CHECK(!p.description.empty());
    for (auto it = p.entries.begin(); it != p.entries.end(); ++it) {
      INFO(p.name << ": " << it.key());
      const std::string k = it.key();
      CHECK(known(envs, k.substr(0, k.find('/'))));
      CHECK(known(algos, k.substr(k.find('/') + 1)));
      CHECK(it.value().at("note").get<std::string>().size() > 10);
      if (const auto t = it.value().find("train"); t != it.value().end())
        for (const char* fixed : {"env", "algo", "seed", "preset"}) CHECK(!t->contains(fixed));
    }
    // Every cell a preset's entry touches resolves under it.
    for (const std::string& env : envs)
      for (const Algorithm& a : algorithms()) {
        if (!find_algorithm(a.name).safety.is_none() && !env_entry(env).has_constraints) continue;
        const json f = config_fragment(p.entries, env, a.name);
        if (f.empty()) continue;
        INFO(p.name << " on " << env << "/" << a.name);
        CHECK_NOTHROW(resolve_run_config({{"train", {{"env", env}, {"algo", a.name}, {"preset", p.name}}}}));
      }
  }
  CHECK(names.count("paper") == 1);
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"preset", "fastest"}}}}),
                    Catch::Contains("train.preset") && Catch::Contains("paper"));
}

TEST_CASE("presets: wildcard sections reach only the cells that use them, and the file wins", "[presets]") {
  const json entries = {
      {"*/*", {{"note", "n"}, {"sac", {{"batch_size", 32}}}, {"train", {{"eval_every", 777}}}}},
      {"table/*", {{"note", "n"}, {"sac", {{"tau", 0.01}}}, {"adversary", {{"sac", {{"tau", 0.5}}}}}}},
      {"table/atacom-sac", {{"note", "n"}, {"sac", {{"tau", 0.02}}}}},
  };
  json f = config_fragment(entries, "table", "atacom-sac");
  CHECK(f["sac"]["batch_size"] == 32);
  CHECK(f["sac"]["tau"] == 0.02);  // the exact key is merged last
  CHECK(f["train"]["eval_every"] == 777);
  CHECK(!f.contains("adversary"));
  CHECK(!f.contains("note"));
  f = config_fragment(entries, "table", "la");  // no learner: no learner section
  CHECK(!f.contains("sac"));
  CHECK(f["train"]["eval_every"] == 777);
  f = config_fragment(entries, "table", "attack");
  CHECK(!f.contains("sac"));
  CHECK(f["adversary"]["sac"]["tau"] == 0.5);
  // The file's keys win over the preset's, the preset's over the defaults.
  const RunConfig rc = resolve_run_config(
      {{"train", {{"env", "table"}, {"algo", "atacom-sac"}}}, {"sac", {{"lr_actor", 1e-3}}}});
  CHECK(rc.learner["lr_actor"] == 1e-3);
  CHECK(rc.learner["lr_alpha"] == 1e-6);          // the paper preset's table entry
  CHECK(rc.learner["target_entropy"] == -10.0);   // the paper preset's table entry
}

TEST_CASE("presets: PPO's tuned settings are preset cells over PPO's generic defaults", "[presets]") {
  // The tuned keys (docs/training.md, "PPO on the envs") reach the PPO cells
  // of the four envs under every layer, in the fast preset and in the paper
  // preset (the default: the paper has no PPO); the learner defaults stay generic.
  for (const char* preset : {"paper", "fast"})
    for (const char* env : {"table", "shelf", "hri", "nav"})
      for (const char* algo : {"ppo", "atacom-ppo", "safelayer-ppo"}) {
        INFO(preset << " " << env << "/" << algo);
        const RunConfig rc = resolve_run_config({{"train", {{"env", env}, {"algo", algo}, {"preset", preset}}}});
        CHECK(rc.train.num_envs == 128);
        CHECK(rc.learner["gamma"] == 0.98);
        CHECK(rc.learner["epochs"] == 5);
        CHECK(rc.learner["minibatch_size"] == 256);
        CHECK(rc.learner["rollout_steps"] == 16);  // PPO's default, not the preset's
      }
  // hri-upright's ATACOM-PPO cell: the same at lr 3e-4 (docs/training.md, "hri-upright").
  for (const char* preset : {"paper", "fast"}) {
    INFO(preset << " hri-upright/atacom-ppo");
    const RunConfig rc =
        resolve_run_config({{"train", {{"env", "hri-upright"}, {"algo", "atacom-ppo"}, {"preset", preset}}}});
    CHECK(rc.train.num_envs == 128);
    CHECK(rc.learner["gamma"] == 0.98);
    CHECK(rc.learner["epochs"] == 5);
    CHECK(rc.learner["minibatch_size"] == 256);
    CHECK(rc.learner["lr_actor"] == 3e-4);
    CHECK(rc.learner["lr_critic"] == 3e-4);
  }
  const json d = learner_entry("ppo").default_config();
  CHECK(d["gamma"] == 0.99);
  CHECK(d["epochs"] == 10);
  CHECK(d["minibatch_size"] == 512);
  const RunConfig pend = resolve_run_config({{"train", {{"env", "pendulum"}, {"algo", "ppo"}, {"preset", "fast"}}}});
  CHECK(pend.learner["gamma"] == 0.99);
  CHECK(pend.train.num_envs == TrainConfig{}.num_envs);
}

TEST_CASE("safety layers: one table, algorithm names are sources x layers, sections only where the layer runs",
          "[presets][algorithms]") {
  const auto& t = safety_layer_entries();
  REQUIRE(t.size() >= 3);
  CHECK(t[0].name == "none");
  CHECK(SafetyLayer::None.is_none());
  CHECK(SafetyLayer::Atacom.name() == "atacom");
  CHECK(SafetyLayer::SafeLayer.name() == "safelayer");
  CHECK(parse_safety_layer("atacom") == SafetyLayer::Atacom);
  CHECK_THROWS_WITH(parse_safety_layer("atacomm"), Catch::Contains("known: none, atacom, safelayer"));
  // Every source under every layer, once.
  CHECK(algorithms().size() == action_sources().size() * t.size());
  for (const ActionSourceEntry& s : action_sources())
    for (SafetyLayer l : safety_layers()) {
      const Algorithm& a = algorithm_for(s.source, s.learner, l);
      CHECK(a.safety == l);
      if (l.is_none()) CHECK(a.name == s.stem);
      else CHECK(a.name == (s.layer_first ? l.name() + "-" + s.stem : s.stem + "-" + l.name()));
    }
  // Layers without parameters write no section and take none.
  const RunConfig rc = resolve_run_config({{"train", {{"env", "table"}, {"algo", "atacom-sac"}}}});
  CHECK(rc.safety == json::object());
  CHECK(!run_config_json(rc).contains("atacom"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "atacom-sac"}}}, {"atacom", {{"x", 1}}}}),
                    Catch::Contains("atacom.x"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "sac"}}}, {"safelayer", json::object()}}),
                    Catch::Contains("'safelayer' does not apply to algo 'sac'"));
}
