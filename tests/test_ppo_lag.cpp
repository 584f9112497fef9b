// PPO-Lagrangian (train/ppo.hpp's cost critic, train/lagrangian_learner.hpp):
// the cost critic leaves PPO's actor and value network bit for bit when the
// multiplier is 0 and moves them when it is not; cost GAE is the reward's
// GAE on the costs; a ppo-lag run's files and keys; 1 and 2 threads and a
// resume inside a rollout give the same bits; and on a task whose only
// violation is avoidable, PPO-Lag learns to cost below its budget while PPO
// does not.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/evaluate.hpp"
#include "atacom/learner.hpp"
#include "atacom/parallel.hpp"
#include "atacom/trainer.hpp"
#include "tests/push_env.hpp"
#include "train/lagrangian_learner.hpp"
#include "train/ppo.hpp"
#include "tests/test_files.hpp"

using nlohmann::json;
using namespace atacom;
using atacom::testing::PushEnv;
namespace fs = std::filesystem;

namespace {

// A filled rollout of T x N rows with random rewards, costs and episode ends.
void fill(PpoRollout& r, Rng& rng) {
  r.steps = r.T;
  r.finals = 0;
  for (auto& x : r.obs) x = float(rng.normal());
  for (auto& x : r.last_obs) x = float(rng.normal());
  for (auto& x : r.sample) x = float(rng.normal() * 0.5);
  for (auto& x : r.logp) x = float(-1.0 + 0.1 * rng.normal());
  for (size_t k = 0; k < r.reward.size(); ++k) {
    r.reward[k] = float(rng.normal());
    r.cost[k] = rng.uniform() < 0.3 ? 1.0f : 0.0f;
    r.terminated[k] = rng.uniform() < 0.05;
    r.truncated[k] = !r.terminated[k] && rng.uniform() < 0.05;
    r.final_row[k] = r.truncated[k] ? r.finals++ : -1;
  }
  for (auto& x : r.final_obs) x = float(rng.normal());
}

// Trains `learner` ("ppo" or "ppo-lag") on PushEnv with 16 envs and
// evaluates its deterministic action over 10 episodes; `max_multiplier`:
// the largest multiplier during training (it may end at 0 once the policy
// costs well below the budget).
EvalResult train_ppo_on_push(const std::string& learner, int64_t batch_steps, double* max_multiplier = nullptr) {
  const int N = 16;
  PushEnv env(N), eval_env(10);
  env.seed(0);
  json ppo = default_ppo_config();
  ppo["actor"]["hidden"] = {32, 32};
  ppo["critic"]["hidden"] = {32, 32};
  ppo["rollout_steps"] = 16;
  ppo["minibatch_size"] = 64;
  ppo["epochs"] = 5;
  ppo["gamma"] = 0.9;
  ppo["lr_actor"] = 3e-3;
  ppo["lr_critic"] = 3e-3;
  const json sections = {{"lagrangian", {{"cost_limit", 5.0}, {"lr", 0.05}, {"kp", 0.0}, {"ki", 0.0}, {"kd", 0.0},
                                         {"init", 0.0}}}};
  LearnerContext ctx{&env.spec(), N, 11, &env.buffers(), &sections};
  auto l = learner_entry(learner).make(ctx, learner_entry(learner).resolve(ppo));
  std::vector<Rng> rngs(static_cast<size_t>(N));
  for (int i = 0; i < N; ++i) rngs[size_t(i)].reseed(11, uint64_t(100 + i));
  std::vector<double> a(static_cast<size_t>(N));
  for (int64_t t = 0; t < batch_steps; ++t) {
    const std::vector<float> obs = env.buffers().obs;
    l->policy().act(obs.data(), N, false, rngs.data(), a.data());
    env.step(a.data());
    l->observe(obs.data(), a.data(), env.buffers());
    if (max_multiplier)
      *max_multiplier = std::max(*max_multiplier, dynamic_cast<LagrangianLearner&>(*l).multiplier().value());
  }
  return evaluate(eval_env, l->policy(), 10, 3, true);
}

}  // namespace

TEST_CASE("ppo cost critic: at multiplier 0 the actor and value network are plain PPO's, and the cost GAE", "[ppo][lagrangian]") {
  PpoConfig c = default_ppo_config();
  c.actor.hidden = {16, 16};
  c.critic.hidden = {16, 16};
  c.rollout_steps = 8;
  c.minibatch_size = 16;
  c.epochs = 2;
  const int N = 4, D = 3, A = 2;
  Ppo plain(D, A, c, 5), lag(D, A, c, 5, true), lag2(D, A, c, 5, true);
  PpoRollout rp, rl, rl2;
  rp.resize(c.rollout_steps, N, D, A, true);  // the costs are ignored without a cost critic
  Rng rng(3, 4);
  for (int u = 0; u < 4; ++u) {
    fill(rp, rng);
    rl = rp;
    rl2 = rp;
    const PpoStats sp = plain.update(rp, 1e-3, 1e-3);
    const PpoStats sl = lag.update(rl, 1e-3, 1e-3, 0.0);
    lag2.update(rl2, 1e-3, 1e-3, 3.0);
    CHECK(sp.policy_loss == sl.policy_loss);
    CHECK(sp.value_loss == sl.value_loss);
    CHECK(sl.cost_value_loss > 0);
    CHECK(rp.advantage == rl.advantage);
    // The cost GAE is compute_gae on the costs with the cost critic's values.
    AlignedVector<float> adv(rl.cost.size()), ret(rl.cost.size());
    compute_gae(rl.T, N, rl.cost.data(), rl.cost_value.data(), rl.cost_last_value.data(), rl.terminated.data(),
                rl.truncated.data(), rl.final_row.data(), rl.cost_final_value.data(), c.gamma, c.gae_lambda,
                adv.data(), ret.data());
    CHECK(adv == rl.cost_advantage);
    CHECK(ret == rl.cost_ret);
    // With w = 3 the actor's advantage is (A_r - 3 A_c) / 4 of that update's values.
    bool combined = true;
    for (size_t k = 0; k < rl2.advantage.size(); ++k) {
      const float a_r = rl2.ret[k] - rl2.value[k];
      combined = combined && std::abs(rl2.advantage[k] - (a_r - 3.0f * rl2.cost_advantage[k]) / 4.0f) <=
                                 1e-5f * (1.0f + std::abs(a_r) + std::abs(rl2.cost_advantage[k]));
    }
    CHECK(combined);
  }
  CHECK(plain.actor().params() == lag.actor().params());
  CHECK(plain.critic().params() == lag.critic().params());
  CHECK(plain.log_std() == lag.log_std());
  CHECK(!plain.has_cost_critic());
  CHECK(lag.cost_critic().params() != lag.critic().params());
  CHECK(lag2.actor().params() != lag.actor().params());
  fill(rl, rng);
  CHECK_THROWS_WITH(lag.update(rl, 1e-3, 1e-3, -1.0), Catch::Contains("cost weight"));
  // save/load round trip with the cost critic
  std::stringstream s;
  lag2.save(s);
  Ppo back(D, A, c, 9, true);
  back.load(s);
  CHECK(back.state_hash() == lag2.state_hash());
  CHECK(back.cost_critic().params() == lag2.cost_critic().params());
}

TEST_CASE("ppo-lag run: files and keys, 1 and 2 threads and a resume inside a rollout give the same bits",
          "[lagrangian][trainer]") {
  const json cfg = {{"ppo", {{"actor", {{"hidden", {16, 16}}}}, {"critic", {{"hidden", {16, 16}}}},
                             {"rollout_steps", 8}, {"minibatch_size", 16}, {"epochs", 2}}},
                    {"lagrangian", {{"cost_limit", 1.0}, {"lr", 0.1}, {"kp", 0.05}}},
                    {"train", {{"env", "table"}, {"algo", "ppo-lag"}, {"steps", 1400}, {"num_envs", 2},
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
  const TrainSummary stopped = train(dp, false, 900);  // batch step 450: 2 steps into a rollout of 8
  REQUIRE(stopped.env_steps == 900);
  const TrainSummary r = train(dp, true, 0);
  set_num_threads(0);
  CHECK(a.updates > 0);
  CHECK(a.agent_hash == b.agent_hash);
  CHECK(r.agent_hash == a.agent_hash);
  CHECK(slurp(d1 + "/policy_final.bin") == slurp(dp + "/policy_final.bin"));
  const json s = json::parse(slurp(d1 + "/summary.json"));
  for (const char* k : {"cost_limit", "train_cost", "eval_cost_mean", "lagrange_multiplier", "rollouts"})
    CHECK(s.contains(k));
  CHECK(s["cost_limit"] == 1.0);
  CHECK(s["train_cost"].get<int64_t>() > 0);
  CHECK(s["lagrange_multiplier"].get<double>() > 0);
  CHECK(s["learner"] == "ppo-lag");
  const json c = json::parse(slurp(d1 + "/config.json"));
  CHECK(c["lagrangian"]["kp"] == 0.05);
  CHECK(c.contains("ppo"));
  std::istringstream csv(slurp(d1 + "/progress.csv"));
  std::string header;
  std::getline(csv, header);
  for (const char* col : {"lagrange_multiplier", "train_episode_cost", "cost_value_loss", "value_loss", "train_cost",
                          "eval_cost_mean"})
    CHECK((header + ",").find(std::string(",") + col + ",") != std::string::npos);
  CHECK_NOTHROW(TrainedPolicy::load(d1));
  for (const auto& d : {d1, d2, dp}) fs::remove_all(d);
}

TEST_CASE("ppo-lag learns to cost below its budget where the only violation is avoidable, ppo does not",
          "[learning][lagrangian]") {
  double lambda = 0;  // the largest multiplier of the run
  const EvalResult lag = train_ppo_on_push("ppo-lag", 2500, &lambda);
  const EvalResult ppo = train_ppo_on_push("ppo", 2500);
  INFO("ppo-lag: cost " << lag.cost_mean << " return " << lag.return_mean << " multiplier " << lambda
                        << "; ppo: cost " << ppo.cost_mean << " return " << ppo.return_mean);
  CHECK(ppo.cost_mean > 40);      // plain PPO pushes on: a > 0.5 nearly every step of 50
  CHECK(lag.cost_mean <= 5.0);    // PPO-Lag stays within the budget of 5 per episode
  CHECK(lag.return_mean > 15.0);  // ... and still pushes (a = 0.3 or more on average)
  CHECK(lambda > 0.0);
}
