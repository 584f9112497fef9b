// SAC-Lagrangian and the Lagrange multiplier (train/lagrangian.hpp,
// train/lagrangian_learner.hpp): the multiplier rises while the episode cost is
// above the budget and falls below it on a synthetic cost stream (plain
// ascent and PID); the cost critic leaves SAC's actor and critics bit for bit
// when the multiplier is 0; the "lagrangian" section (defaults, presets,
// strict keys, only for the Lagrangian learners); a sac-lag run's files and
// keys; 1 and 2 threads and a resume give the same bits; and on a task whose
// only violation is avoidable, SAC-Lag learns to cost below its budget while
// SAC does not.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/evaluate.hpp"
#include "atacom/learner.hpp"
#include "atacom/parallel.hpp"
#include "atacom/trainer.hpp"
#include "train/lagrangian.hpp"
#include "train/sac.hpp"
#include "train/lagrangian_learner.hpp"
#include "tests/push_env.hpp"
#include "tests/test_files.hpp"

using nlohmann::json;
using namespace atacom;
using atacom::testing::PushEnv;
namespace fs = std::filesystem;

namespace {

// Trains `learner` ("sac" or "sac-lag") on PushEnv with N = 1 for `steps`
// steps and evaluates its mean action over 10 episodes.
EvalResult train_sac_on_push(const std::string& learner, int64_t steps, double* multiplier = nullptr) {
  PushEnv env(1), eval_env(10);
  env.seed(0);
  json sac = default_sac_config();
  sac["actor"]["hidden"] = {64, 64};
  sac["critic"]["hidden"] = {64, 64};
  sac["lr_actor"] = 1e-3;
  sac["lr_critic"] = 1e-3;
  sac["lr_alpha"] = 1e-3;
  sac["gamma"] = 0.9;
  sac["initial_replay"] = 500;
  sac["warmup"] = 500;
  sac["replay_capacity"] = 20000;
  const json sections = {{"lagrangian", {{"cost_limit", 5.0}, {"lr", 0.02}, {"kp", 0.0}, {"ki", 0.0}, {"kd", 0.0},
                                         {"init", 0.0}}}};
  LearnerContext ctx{&env.spec(), 1, 11, &env.buffers(), &sections};
  auto l = learner_entry(learner).make(ctx, learner_entry(learner).resolve(sac));
  std::vector<Rng> rngs(1);
  rngs[0].reseed(11, 99);
  std::vector<double> a(1);
  for (int64_t t = 0; t < steps; ++t) {
    const std::vector<float> obs = env.buffers().obs;
    l->policy().act(obs.data(), 1, false, rngs.data(), a.data());
    env.step(a.data());
    l->observe(obs.data(), a.data(), env.buffers());
  }
  if (multiplier) *multiplier = dynamic_cast<LagrangianLearner&>(*l).multiplier().value();
  return evaluate(eval_env, l->policy(), 10, 3, true);
}

}  // namespace

TEST_CASE("lagrange multiplier: rises while the episode cost is above the budget, falls below it", "[lagrangian]") {
  LagrangianConfig c;
  c.cost_limit = 10;
  c.lr = 0.1;
  LagrangeMultiplier m(c);
  CHECK(m.value() == 0.0);
  double prev = m.value();
  for (int t = 0; t < 50; ++t) {  // episodes costing 25 > 10
    m.update(25.0);
    CHECK(m.value() > prev);
    prev = m.value();
  }
  CHECK(m.value() == Approx(50 * 0.1 * 15));
  for (int t = 0; t < 200; ++t) {  // now 4 < 10: down, to 0 and no further
    m.update(4.0);
    CHECK(m.value() <= prev);
    CHECK(m.value() >= 0.0);
    if (prev > 0) CHECK(m.value() < prev);
    prev = m.value();
  }
  CHECK(m.value() == 0.0);
  m.update(10.0);  // on budget: no move
  CHECK(m.value() == 0.0);
  CHECK(m.updates() == 251);
  // The pinned formula: I += (lr + ki) e (clipped at 0), lambda = max(0, I + kp e + kd max(0, J - J_prev)).
  LagrangianConfig p;
  p.cost_limit = 5;
  p.lr = 0.01;
  p.kp = 0.5;
  p.ki = 0.04;
  p.kd = 0.2;
  p.init = 1.0;
  LagrangeMultiplier q(p);
  CHECK(q.value() == 1.0);
  q.update(15);  // e = 10: I = 1 + 0.05 * 10 = 1.5; P = 5; no D at the first episode
  CHECK(q.value() == Approx(6.5));
  q.update(25);  // e = 20: I = 2.5; P = 10; D = 0.2 * 10 = 2
  CHECK(q.value() == Approx(14.5));
  q.update(5);  // e = 0: I = 2.5; P = 0; D = 0 (a fall is not damped)
  CHECK(q.value() == Approx(2.5));
  q.update(0);  // e = -5: I = 2.25, P = -2.5 -> 0 (clipped)
  CHECK(q.value() == 0.0);
  // save / load round trip, and a corrupt state refused
  std::stringstream s;
  q.save(s);
  LagrangeMultiplier r(p);
  r.load(s);
  CHECK(r.value() == q.value());
  CHECK(r.updates() == q.updates());
  r.update(30);
  q.update(30);
  CHECK(r.value() == q.value());
}

TEST_CASE("lagrangian section: defaults, per-env presets, strict keys, only for the Lagrangian learners", "[lagrangian]") {
  const json d = default_lagrangian_config();
  for (const char* k : {"cost_limit", "lr", "kp", "ki", "kd", "init"}) CHECK(d.contains(k));
  CHECK(d.size() == 6);
  RunConfig rc = resolve_run_config({{"train", {{"env", "table"}, {"algo", "sac-lag"}}}});
  CHECK(rc.learner_sections["lagrangian"]["cost_limit"] == 5.0);        // the paper preset's table entry
  CHECK(rc.learner["lr_actor"] == 1e-5);                                // as plain SAC there
  CHECK(rc.learner["target_entropy"] == -10.0);                         // the table/* entry reaches sac-lag
  CHECK(resolve_run_config({{"train", {{"env", "nav"}, {"algo", "sac-lag"}}}}).learner_sections["lagrangian"]["cost_limit"] ==
        1.0);
  const json file = {{"train", {{"env", "table"}, {"algo", "sac-lag"}}},
                     {"lagrangian", {{"cost_limit", 2.5}, {"kp", 0.1}}}};
  rc = resolve_run_config(file);
  CHECK(rc.learner_sections["lagrangian"]["cost_limit"] == 2.5);
  CHECK(rc.learner_sections["lagrangian"]["kp"] == 0.1);
  CHECK(rc.learner_sections["lagrangian"]["lr"] == d["lr"]);
  const json written = run_config_json(rc);
  CHECK(written["lagrangian"] == rc.learner_sections["lagrangian"]);
  CHECK(written.contains("sac"));
  CHECK(run_config_json(resolve_run_config(written)) == written);  // config.json re-runs the run
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "sac"}}}, {"lagrangian", json::object()}}),
                    Catch::Contains("'lagrangian' does not apply"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "la"}}}, {"lagrangian", json::object()}}),
                    Catch::Contains("does not apply"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "sac-lag"}}}, {"lagrangian", {{"limit", 1}}}}),
                    Catch::Contains("lagrangian.limit"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "table"}, {"algo", "sac-lag"}}}, {"lagrangian", {{"lr", -1}}}}),
                    Catch::Contains("lagrangian.lr"));
  // Every safety layer composes with it: atacom-sac-lag, cbf-sac-lag, ...
  CHECK_NOTHROW(resolve_run_config({{"train", {{"env", "nav"}, {"algo", "cbf-sac-lag"}}}}));
}

TEST_CASE("sac cost critic: with the multiplier at 0 the actor and reward critics are plain SAC's, bit for bit", "[sac]") {
  SacConfig c;
  c.actor.hidden = {32, 32};
  c.critic.hidden = {32, 32};
  c.batch_size = 16;
  Sac plain(3, 2, c, 5), lag(3, 2, c, 5, true);
  ReplayBatch b;
  b.resize(16, 3, 2);
  Rng rng(1, 2);
  for (int u = 0; u < 20; ++u) {
    for (auto& x : b.obs) x = float(rng.normal());
    for (auto& x : b.next_obs) x = float(rng.normal());
    for (auto& x : b.action) x = float(rng.uniform(-1, 1));
    for (auto& x : b.reward) x = float(rng.normal());
    for (auto& x : b.cost) x = rng.uniform() < 0.3 ? 1.0f : 0.0f;
    for (auto& x : b.terminated) x = rng.uniform() < 0.1 ? 1.0f : 0.0f;
    const SacStats sp = plain.update(b, u >= 5);
    const SacStats sl = lag.update(b, u >= 5, 0.0);
    CHECK(sp.critic_loss == sl.critic_loss);
    CHECK(sp.actor_loss == sl.actor_loss);
    CHECK(sl.cost_critic_loss > 0);
  }
  CHECK(plain.actor().params() == lag.actor().params());
  CHECK(plain.critic().params() == lag.critic().params());
  CHECK(plain.critic_target().params() == lag.critic_target().params());
  CHECK(plain.log_alpha() == lag.log_alpha());
  CHECK(!plain.has_cost_critic());
  CHECK(lag.cost_critic().params() != lag.critic().params());
  // A positive multiplier moves the actor away from plain SAC's.
  Sac lag2(3, 2, c, 5, true);
  for (int u = 0; u < 3; ++u) lag2.update(b, true, 2.0);
  Sac plain2(3, 2, c, 5);
  for (int u = 0; u < 3; ++u) plain2.update(b, true);
  CHECK(plain2.actor().params() != lag2.actor().params());
  CHECK_THROWS_WITH(lag2.update(b, true, -1.0), Catch::Contains("cost weight"));
}

TEST_CASE("sac-lag run: files and keys, 1 and 2 threads and a resume give the same bits", "[lagrangian][trainer]") {
  const json cfg = {{"sac", {{"actor", {{"hidden", {32, 32}}}}, {"critic", {{"hidden", {32, 32}}}}, {"batch_size", 32},
                             {"initial_replay", 200}, {"warmup", 300}, {"replay_capacity", 5000}}},
                    {"lagrangian", {{"cost_limit", 1.0}, {"lr", 0.1}, {"kp", 0.05}}},
                    {"train", {{"env", "table"}, {"algo", "sac-lag"}, {"steps", 1400}, {"num_envs", 2},
                               {"eval_every", 400}, {"eval_episodes", 2}, {"seed", 4}}}};
  const std::string d1 = tmp_dir("t1"), d2 = tmp_dir("t2"), dp = tmp_dir("part");
  auto train = [&](const std::string& dir, bool resume, int64_t stop) {
    TrainOptions o;
    o.out_dir = dir;
    o.resume = resume;
    o.stop_after = stop;
    return run_training(resolve_run_config(cfg), o);
  };
  set_num_threads(1);
  const TrainSummary a = train(d1, false, 0);
  set_num_threads(2);
  const TrainSummary b = train(d2, false, 0);
  const TrainSummary stopped = train(dp, false, 900);
  REQUIRE(stopped.env_steps == 900);
  const TrainSummary r = train(dp, true, 0);
  set_num_threads(0);
  CHECK(a.updates > 500);
  CHECK(a.agent_hash == b.agent_hash);
  CHECK(r.agent_hash == a.agent_hash);
  CHECK(slurp(d1 + "/policy_final.bin") == slurp(dp + "/policy_final.bin"));
  const json s = json::parse(slurp(d1 + "/summary.json"));
  for (const char* k : {"cost_limit", "train_cost", "eval_cost_mean", "lagrange_multiplier", "alpha"})
    CHECK(s.contains(k));
  CHECK(s["cost_limit"] == 1.0);
  CHECK(s["train_cost"].get<int64_t>() > 0);  // an untrained arm hits rows and limits
  CHECK(s["lagrange_multiplier"].get<double>() > 0);
  CHECK(s["learner"] == "sac-lag");
  const json c = json::parse(slurp(d1 + "/config.json"));
  CHECK(c["lagrangian"]["kp"] == 0.05);
  CHECK(c.contains("sac"));
  std::istringstream csv(slurp(d1 + "/progress.csv"));
  std::string header;
  std::getline(csv, header);
  for (const char* col : {"lagrange_multiplier", "train_episode_cost", "cost_critic_loss", "cost_q_mean", "train_cost",
                          "eval_cost_mean"})
    CHECK((header + ",").find(std::string(",") + col + ",") != std::string::npos);
  CHECK(without_wall(slurp(d1 + "/progress.csv")) == without_wall(slurp(d2 + "/progress.csv")));
  CHECK(without_wall(slurp(d1 + "/progress.csv")) == without_wall(slurp(dp + "/progress.csv")));
  // The trained policy loads from the directory like SAC's.
  CHECK_NOTHROW(TrainedPolicy::load(d1));
  for (const auto& d : {d1, d2, dp}) fs::remove_all(d);
}

TEST_CASE("sac-lag learns to cost below its budget where the only violation is avoidable, sac does not",
          "[learning][lagrangian]") {
  double lambda = 0;
  const EvalResult lag = train_sac_on_push("sac-lag", 12000, &lambda);
  const EvalResult sac = train_sac_on_push("sac", 12000);
  INFO("sac-lag: cost " << lag.cost_mean << " return " << lag.return_mean << " multiplier " << lambda
                        << "; sac: cost " << sac.cost_mean << " return " << sac.return_mean);
  CHECK(sac.cost_mean > 40);        // plain SAC pushes on: a > 0.5 nearly every step of 50
  CHECK(lag.cost_mean <= 5.0);      // SAC-Lag stays within the budget of 5 per episode
  CHECK(lag.return_mean > 15.0);    // ... and still pushes (a = 0.3 or more on average)
  CHECK(lambda > 0.0);
}
