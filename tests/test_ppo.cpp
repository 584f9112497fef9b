#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <unistd.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/evaluate.hpp"
#include "atacom/parallel.hpp"
#include "atacom/trainer.hpp"
#include "train/ppo.hpp"
#include "train/ppo_learner.hpp"
#include "train/ppo_rollout.hpp"
#include "tests/test_files.hpp"
#include "tests/train_run.hpp"

namespace fs = std::filesystem;
using atacom::Mlp;
using atacom::PpoConfig;
using atacom::Rng;
using atacom::Tape;
using nlohmann::json;

namespace {

// A short pendulum run: N 4, T 16 (64 transitions per update), 2 minibatches.
json small_ppo_run(int64_t steps) {
  return {{"ppo", {{"actor", {{"hidden", {32, 32}}}}, {"critic", {{"hidden", {32, 32}}}}, {"rollout_steps", 16},
                   {"epochs", 3}, {"minibatch_size", 32}, {"lr_actor", 1e-3}, {"lr_critic", 1e-3}}},
          {"train", {{"env", "pendulum"}, {"algo", "ppo"}, {"steps", steps}, {"num_envs", 4}, {"eval_every", 200},
                     {"eval_episodes", 3}, {"seed", 5}}},
          {"env", {{"horizon", 50}}}};
}

}  // namespace

TEST_CASE("ppo: config defaults, JSON round trip and strict ranges", "[ppo]") {
  const PpoConfig d = atacom::default_ppo_config();
  REQUIRE(d.actor.hidden == std::vector<int>{64, 64});
  REQUIRE(d.actor.activation == atacom::Activation::Relu);
  REQUIRE(d.rollout_steps == 16);
  REQUIRE(d.minibatch_size == 512);
  REQUIRE(d.clip_range == 0.2);
  REQUIRE(d.gae_lambda == 0.95);
  REQUIRE(!d.target_kl.has_value());
  REQUIRE(!d.value_clip_range.has_value());
  PpoConfig c = d;
  c.target_kl = 0.02;
  c.value_clip_range = 0.5;
  c.log_std = atacom::LogStdMode::StateDependent;
  c.lr_schedule = atacom::LrSchedule::Linear;
  c.critic.hidden = {7, 5};
  const PpoConfig back = json(c).get<PpoConfig>();
  REQUIRE(json(back) == json(c));
  REQUIRE(back.log_std == atacom::LogStdMode::StateDependent);
  REQUIRE(json(d)["log_std"] == "state_independent");
  REQUIRE(json(d)["target_kl"].is_null());
  REQUIRE_THROWS_WITH((json{{"epoch", 3}}.get<PpoConfig>()), Catch::Contains("ppo.epoch"));
  REQUIRE_THROWS_WITH((json{{"clip_range", 0}}.get<PpoConfig>()), Catch::Contains("ppo.clip_range"));
  REQUIRE_THROWS_WITH((json{{"clip_range", 1.5}}.get<PpoConfig>()), Catch::Contains("(0, 1]"));
  REQUIRE_THROWS_WITH((json{{"rollout_steps", 0}}.get<PpoConfig>()), Catch::Contains("ppo.rollout_steps"));
  REQUIRE_THROWS_WITH((json{{"minibatch_size", 1 << 20}}.get<PpoConfig>()), Catch::Contains("ppo.minibatch_size"));
  REQUIRE_THROWS_WITH((json{{"gae_lambda", 1.01}}.get<PpoConfig>()), Catch::Contains("ppo.gae_lambda"));
  REQUIRE_THROWS_WITH((json{{"target_kl", -1}}.get<PpoConfig>()), Catch::Contains("ppo.target_kl"));
  REQUIRE_THROWS_WITH((json{{"log_std", "learned"}}.get<PpoConfig>()),
                      Catch::Contains("ppo.log_std") && Catch::Contains("state_dependent"));
  REQUIRE_THROWS_WITH((json{{"lr_schedule", "cosine"}}.get<PpoConfig>()), Catch::Contains("linear"));
  REQUIRE_THROWS_WITH((json{{"init_log_std", 3.0}}.get<PpoConfig>()), Catch::Contains("init_log_std"));
  REQUIRE_THROWS_WITH((json{{"actor", {{"hidden", {0}}}}}.get<PpoConfig>()), Catch::Contains("ppo.actor.hidden"));
  REQUIRE_THROWS_WITH((json{{"critic", {{"width", 3}}}}.get<PpoConfig>()), Catch::Contains("ppo.critic.width"));
  // a network's keys lay over PPO's default network
  const PpoConfig tanh = json{{"actor", {{"activation", "tanh"}}}}.get<PpoConfig>();
  REQUIRE(tanh.actor.hidden == std::vector<int>{64, 64});
  REQUIRE(tanh.actor.activation == atacom::Activation::Tanh);
  // linear schedule: the factor falls to 0 at lr_decay_steps and stays there
  c.lr_decay_steps = 1000;
  REQUIRE(atacom::ppo_lr_factor(c, 0) == 1.0);
  REQUIRE(atacom::ppo_lr_factor(c, 250) == 0.75);
  REQUIRE(atacom::ppo_lr_factor(c, 5000) == 0.0);
  REQUIRE(atacom::ppo_lr_factor(d, 5000) == 1.0);
  // the run config: "ppo" resolves for the ppo algorithms and is refused for SAC's
  json run = {{"train", {{"env", "pendulum"}, {"algo", "ppo"}}}, {"ppo", {{"epochs", 4}}}};
  REQUIRE(atacom::resolve_run_config(run).learner["epochs"] == 4);
  run["train"]["algo"] = "sac";
  REQUIRE_THROWS_WITH(atacom::resolve_run_config(run), Catch::Contains("'ppo' does not apply"));
}

// T = 4, N = 3, gamma = lambda = 0.5: env 0 truncated at t = 1 (final value
// 10), env 1 terminated at t = 2, env 2 terminated at its last step (s_T's
// value must not leak in). Values computed by hand, exact in binary.
TEST_CASE("ppo: GAE matches a hand-computed reference with truncation and termination", "[ppo]") {
  const int T = 4, N = 3;
  // time-major: row t * N + i
  const std::vector<float> reward = {1, 1, 0, 2, 1, 0, 3, 1, 0, 4, 1, 5};
  const std::vector<float> value = {0.5f, 1, 1, 1, 2, 1, 1.5f, 3, 1, 2, 4, 1};
  const std::vector<float> last = {4, 8, 100};
  std::vector<uint8_t> term(12, 0), trunc(12, 0);
  std::vector<int32_t> final_row(12, -1);
  trunc[1 * N + 0] = 1;
  final_row[1 * N + 0] = 0;
  term[2 * N + 1] = 1;
  term[3 * N + 2] = 1;
  const std::vector<float> final_value = {10};
  std::vector<float> adv(12), ret(12);
  atacom::compute_gae(T, N, reward.data(), value.data(), last.data(), term.data(), trunc.data(), final_row.data(),
                      final_value.data(), 0.5, 0.5, adv.data(), ret.data());
  // env 0: A3 = 4 + .5*4 - 2 = 4; A2 = 3 + .5*2 - 1.5 + .25*4 = 3.5; A1 = 2 + .5*10 - 1 = 6 (cut);
  //        A0 = 1 + .5*1 - .5 + .25*6 = 2.5
  // env 1: A3 = 1 + .5*8 - 4 = 1; A2 = 1 - 3 = -2 (terminal); A1 = 1 + 1.5 - 2 + .25*(-2) = 0; A0 = 1 + 1 - 1 = 1
  // env 2: A3 = 5 - 1 = 4; A2 = .5 - 1 + 1 = .5; A1 = -.5 + .125 = -.375; A0 = -.5 - .09375 = -.59375
  const std::vector<float> expect = {2.5f, 1, -0.59375f, 6, 0, -0.375f, 3.5f, -2, 0.5f, 4, 1, 4};
  for (int k = 0; k < 12; ++k) {
    INFO("row " << k);
    CHECK(adv[size_t(k)] == expect[size_t(k)]);
    CHECK(ret[size_t(k)] == expect[size_t(k)] + value[size_t(k)]);
  }
  // lambda = 0: one-step TD errors; lambda = 1: discounted returns to the episode's end
  atacom::compute_gae(T, N, reward.data(), value.data(), last.data(), term.data(), trunc.data(), final_row.data(),
                      final_value.data(), 0.5, 1.0, adv.data(), ret.data());
  CHECK(ret[0 * N + 1] == 1 + 0.5f * (1 + 0.5f * 1));  // env 1 from t = 0: rewards 1, 1, 1 then the terminal
  CHECK(ret[0 * N + 0] == 1 + 0.5f * (2 + 0.5f * 10));  // env 0: 1, 2 and the truncation's bootstrap
}

namespace {
// Central differences of a scalar function of one parameter buffer.
void check_fd(const char* what, std::vector<double*> params, const std::vector<size_t>& sizes,
              const std::vector<const double*>& grads, const std::function<double()>& loss) {
  const double h = 1e-6;
  int checked = 0;
  for (size_t b = 0; b < params.size(); ++b)
    for (size_t i = 0; i < sizes[b]; ++i) {
      double& p = params[b][i];
      const double keep = p;
      p = keep + h;
      const double lp = loss();
      p = keep - h;
      const double lm = loss();
      p = keep;
      const double fd = (lp - lm) / (2 * h);
      INFO(what << ": buffer " << b << " element " << i << " analytic " << grads[b][i] << " fd " << fd);
      REQUIRE(std::abs(grads[b][i] - fd) <= 1e-6 * (1.0 + std::abs(fd)));
      ++checked;
    }
  REQUIRE(checked > 0);
}
}  // namespace

TEST_CASE("ppo: surrogate, entropy and value gradients match finite differences", "[ppo]") {
  const int D = 3, A = 2, B = 9;
  for (const bool dependent : {false, true}) {
    for (const bool clip_value : {false, true}) {
      INFO("state-dependent log-std " << dependent << ", clipped value loss " << clip_value);
      PpoConfig c = atacom::default_ppo_config();
      c.actor.hidden = c.critic.hidden = {5};
      c.entropy_coef = 0.03;
      c.clip_range = 0.2;
      if (clip_value) c.value_clip_range = 0.3;
      if (dependent) c.log_std = atacom::LogStdMode::StateDependent;
      Mlp<double> actor(D, dependent ? 2 * A : A, c.actor), critic(D, 1, c.critic);
      Rng init(11, 0);
      actor.init(init);
      critic.init(init);
      std::vector<double> log_std = {-0.3, 0.2}, log_std_grad(2, 0.0);
      std::vector<double> obs(B * D), u(B * A), logp_old(B), adv(B), ret(B), v_old(B);
      Rng r(12, 0);
      for (auto& x : obs) x = r.uniform(-1, 1);
      for (auto& x : u) x = r.uniform(-1.5, 1.5);
      for (auto& x : adv) x = r.uniform(-2, 2);
      for (auto& x : ret) x = r.uniform(-1, 1);
      // The old log-densities: the current ones shifted so that some ratios
      // sit inside the clip range and some outside (away from the kinks).
      {
        Tape<double> t;
        const auto l = atacom::record_ppo_actor_loss<double>(t, actor, dependent ? nullptr : log_std.data(),
                                                             log_std_grad.data(), A, c, obs.data(), u.data(),
                                                             logp_old.data(), adv.data(), B);
        const double shifts[3] = {0.05, -0.5, 0.6};  // ratio 0.95, 1.65, 0.55
        for (int i = 0; i < B; ++i) logp_old[size_t(i)] = t.value(l.logp).data[i] + shifts[i % 3];
        const auto v = critic.forward(t, t.constant(obs.data(), B, D), false);
        const double vs[3] = {0.1, -0.6, 0.8};  // inside and outside the value clip range 0.3
        for (int i = 0; i < B; ++i) v_old[size_t(i)] = t.value(v).data[i] + vs[i % 3];
      }
      auto actor_loss = [&]() {
        Tape<double> t;
        const auto l = atacom::record_ppo_actor_loss<double>(t, actor, dependent ? nullptr : log_std.data(),
                                                             log_std_grad.data(), A, c, obs.data(), u.data(),
                                                             logp_old.data(), adv.data(), B);
        return t.scalar(l.loss);
      };
      auto value_loss = [&]() {
        Tape<double> t;
        return t.scalar(atacom::record_ppo_value_loss<double>(t, critic, c, obs.data(), ret.data(), v_old.data(), B));
      };
      {
        Tape<double> t;
        const auto l = atacom::record_ppo_actor_loss<double>(t, actor, dependent ? nullptr : log_std.data(),
                                                             log_std_grad.data(), A, c, obs.data(), u.data(),
                                                             logp_old.data(), adv.data(), B);
        t.backward(l.loss);
        // The loss is what the header says, term by term.
        double pg = 0, ls_sum = 0;
        for (int i = 0; i < B; ++i) {
          const double ratio = std::exp(t.value(l.logp).data[i] - logp_old[size_t(i)]);
          const double a = adv[size_t(i)];
          pg += std::min(ratio * a, std::min(std::max(ratio, 0.8), 1.2) * a);
        }
        pg = -pg / B;
        REQUIRE(t.scalar(l.policy_loss) == Approx(pg).epsilon(1e-12));
        if (!dependent) ls_sum = log_std[0] + log_std[1];
        if (!dependent) REQUIRE(t.scalar(l.log_std_sum) == Approx(ls_sum).epsilon(1e-12));
        REQUIRE(t.scalar(l.loss) == Approx(pg - c.entropy_coef * t.scalar(l.log_std_sum)).epsilon(1e-12));
      }
      const std::vector<double> ga(actor.grads().begin(), actor.grads().end());
      const std::vector<double> gl = log_std_grad;
      std::vector<double*> ap = {actor.params().data()};
      std::vector<size_t> as = {actor.params().size()};
      std::vector<const double*> ag = {ga.data()};
      if (!dependent) {
        ap.push_back(log_std.data());
        as.push_back(log_std.size());
        ag.push_back(gl.data());
      }
      check_fd("actor", ap, as, ag, actor_loss);
      {
        Tape<double> t;
        t.backward(atacom::record_ppo_value_loss<double>(t, critic, c, obs.data(), ret.data(), v_old.data(), B));
      }
      const std::vector<double> gc(critic.grads().begin(), critic.grads().end());
      check_fd("critic", {critic.params().data()}, {critic.params().size()}, {gc.data()}, value_loss);
    }
  }
}

namespace {
struct Bench {
  std::unique_ptr<atacom::BatchEnv> env;
  std::unique_ptr<atacom::PpoLearner> learner;
  std::vector<Rng> rngs;
  std::vector<float> obs;
  std::vector<double> actions;
  int N;
  Bench(const std::string& name, int n, const PpoConfig& c, const json& env_cfg = json::object()) : N(n) {
    env = atacom::make_env(atacom::EnvRequest{name, n, atacom::SafetyLayer::None, env_cfg});
    env->seed(3);
    const atacom::LearnerContext ctx{&env->spec(), n, 3, &env->buffers()};
    learner = std::make_unique<atacom::PpoLearner>(ctx, c);
    for (int i = 0; i < n; ++i) rngs.emplace_back(3, uint64_t(1000 + i));
    obs = env->buffers().obs;
    actions.assign(size_t(n) * size_t(env->spec().act_dim), 0.0);
  }
  void step() {
    learner->policy().act(obs.data(), N, false, rngs.data(), actions.data());
    env->step(actions.data());
    learner->observe(obs.data(), actions.data(), env->buffers());
    obs = env->buffers().obs;
  }
};

PpoConfig tiny_config() {
  PpoConfig c = atacom::default_ppo_config();
  c.actor.hidden = c.critic.hidden = {16};
  c.rollout_steps = 8;
  c.epochs = 2;
  c.minibatch_size = 8;
  return c;
}
}  // namespace

// The choice docs/training.md states: the env gets clip(u) (ATACOM reads it
// as alpha unchanged), the rollout keeps u, and log pi is u's Gaussian density.
TEST_CASE("ppo: actions are clip(u), the rollout keeps the pre-clip sample u and its Gaussian log-density", "[ppo]") {
  for (const bool dependent : {false, true}) {
    INFO("state-dependent " << dependent);
    PpoConfig c = tiny_config();
    c.init_log_std = 0.4;          // std 1.5: many samples outside [-1, 1]
    c.init_output_scale = 3.0;     // means beyond the box too
    if (dependent) c.log_std = atacom::LogStdMode::StateDependent;
    Bench b("table", 64, c);
    const int A = 7, D = 16, N = 64;
    auto& learner = *b.learner;
    auto& policy = learner.policy();
    // the means, from the actor on the normalised observations
    std::vector<float> nobs(size_t(N) * D);
    learner.obs_norm().map().apply(b.obs.data(), nobs.data(), N);
    Tape<float> t;
    const auto out = learner.agent().actor().forward(t, t.constant(nobs.data(), N, D), false);
    const float* o = t.value(out).data;
    const int W = dependent ? 2 * A : A;
    std::vector<double> det(size_t(N) * A);
    policy.act(b.obs.data(), N, true, nullptr, det.data());
    int outside_mean = 0;
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < A; ++j) {
        const float mu = o[i * W + j];
        outside_mean += std::abs(mu) > 1;
        REQUIRE(det[size_t(i * A + j)] == std::min(std::max(double(mu), -1.0), 1.0));
      }
    REQUIRE(outside_mean > 0);
    b.step();  // samples, steps, stores
    const auto& r = learner.rollout();
    REQUIRE(r.steps == 1);
    int outside = 0;
    for (int i = 0; i < N; ++i) {
      double ref = 0;
      for (int j = 0; j < A; ++j) {
        const double u = r.sample[size_t(i * A + j)];
        outside += std::abs(u) > 1;
        REQUIRE(b.actions[size_t(i * A + j)] == std::min(std::max(u, -1.0), 1.0));
        const double mu = o[i * W + j];
        const double ls = dependent ? std::min(std::max(double(o[i * W + A + j]), c.log_std_min), c.log_std_max)
                                    : double(learner.agent().log_std()[size_t(j)]);
        const double z = (u - mu) / std::exp(ls);
        ref += -0.5 * z * z - ls - 0.5 * std::log(2 * M_PI);
      }
      REQUIRE(r.logp[size_t(i)] == Approx(ref).epsilon(1e-5));
    }
    REQUIRE(outside > N * A / 4);
    // observe() refuses actions that are not the policy's last sample
    std::vector<double> other = b.actions;
    other[3] = other[3] > 0 ? other[3] - 0.5 : other[3] + 0.5;
    b.learner->policy().act(b.obs.data(), N, false, b.rngs.data(), b.actions.data());
    b.env->step(b.actions.data());
    REQUIRE_THROWS_WITH(learner.observe(b.obs.data(), other.data(), b.env->buffers()),
                        Catch::Contains("did not sample"));
  }
}

TEST_CASE("ppo: the rollout keeps truncated episodes' true last observations and flags every boundary", "[ppo]") {
  PpoConfig c = tiny_config();
  c.rollout_steps = 8;
  Bench b("pendulum", 3, c, {{"horizon", 5}});
  for (int s = 0; s < 7; ++s) {
    const auto& before = b.learner->rollout();
    const int finals = before.finals;
    b.learner->policy().act(b.obs.data(), 3, false, b.rngs.data(), b.actions.data());
    b.env->step(b.actions.data());
    const auto& buf = b.env->buffers();
    const atacom::ObsNorm map_before = b.learner->obs_norm().map();  // what the policy acted with
    b.learner->observe(b.obs.data(), b.actions.data(), buf);
    const auto& r = b.learner->rollout();
    for (int i = 0; i < 3; ++i) {
      const size_t k = size_t(s) * 3 + size_t(i);
      REQUIRE(r.truncated[k] == (s == 4 ? 1 : 0));  // horizon 5: the fifth step of every env
      REQUIRE(r.terminated[k] == 0);
      if (s == 4) {
        REQUIRE(r.final_row[k] == finals + i);
        std::vector<float> expect(3);
        map_before.apply(buf.final_obs.data() + size_t(i) * 3, expect.data(), 1);
        for (int j = 0; j < 3; ++j) REQUIRE(r.final_obs[size_t(r.final_row[k]) * 3 + size_t(j)] == expect[size_t(j)]);
        REQUIRE(buf.final_obs[size_t(i) * 3] != buf.obs[size_t(i) * 3]);  // the next episode's first obs differs
      } else {
        REQUIRE(r.final_row[k] == -1);
      }
    }
    b.obs = buf.obs;
  }
  REQUIRE(b.learner->rollout().finals == 3);
  REQUIRE(b.learner->updates() == 0);
  b.step();  // the eighth step completes the rollout: one update of 2 epochs x 3 minibatches
  REQUIRE(b.learner->rollout().steps == 0);
  REQUIRE(b.learner->updates() == 2 * 3);
}

TEST_CASE("ppo: updates count minibatch steps, the progress columns, and the KL stop", "[ppo]") {
  const std::string dir = tmp_dir("count");
  const auto s = train(small_ppo_run(400), dir);
  // 400 steps of N 4: 6 full rollouts of 64 (T 16), each 3 epochs x 2 minibatches of 32
  REQUIRE(s.env_steps == 400);
  REQUIRE(s.updates == 6 * 3 * 2);
  std::istringstream csv(slurp(dir + "/progress.csv"));
  std::string header;
  std::getline(csv, header);
  REQUIRE(header.find("train_episode_return,policy_loss,value_loss,entropy,approx_kl,clip_fraction,"
                      "explained_variance,learning_rate,epochs,") != std::string::npos);
  const json sum = json::parse(slurp(dir + "/summary.json"));
  REQUIRE(sum["learner"] == "ppo");
  REQUIRE(sum["rollouts"] == 6);
  REQUIRE(sum["learning_rate"] == 1e-3);
  fs::remove_all(dir);
  // A tiny target_kl stops every update after its first step: the first
  // minibatch's ratio is 1 (up to rounding), the second's is not.
  json cfg = small_ppo_run(400);
  cfg["ppo"]["target_kl"] = 1e-9;
  const auto k = train(cfg, dir);
  REQUIRE(k.updates == 6);
  fs::remove_all(dir);
}

TEST_CASE("ppo: stopped inside a rollout and resumed == uninterrupted, bitwise", "[ppo]") {
  // Rollouts of 64 env steps: the stop at 120 and the evaluation at 200 both
  // fall inside one (batch steps 30 and 50 of T 16).
  json cfg = small_ppo_run(400);
  cfg["ppo"]["lr_schedule"] = "linear";
  cfg["ppo"]["lr_decay_steps"] = 1000;
  cfg["ppo"]["value_clip_range"] = 1.0;
  const std::string full = tmp_dir("full"), part = tmp_dir("part");
  const auto u = train(cfg, full);
  const auto stopped = train(cfg, part, false, 120);
  REQUIRE(stopped.env_steps == 120);
  REQUIRE(json::parse(slurp(part + "/checkpoint.json"))["rollout_step"] == 14);
  const auto r = train(cfg, part, true);
  REQUIRE(r.env_steps == 400);
  REQUIRE(r.agent_hash == u.agent_hash);
  REQUIRE(without_wall(slurp(part + "/progress.csv")) == without_wall(slurp(full + "/progress.csv")));
  REQUIRE(r.final_eval.return_mean == u.final_eval.return_mean);
  REQUIRE(slurp(part + "/policy_final.bin") == slurp(full + "/policy_final.bin"));
  fs::remove_all(full);
  fs::remove_all(part);
}

TEST_CASE("ppo: bitwise identical with 1 and 2 threads", "[ppo]") {
  // Above one GEMM tile (256 rows x 128 columns) and the TBB thresholds:
  // N 64, T 8, minibatches of 256.
  json cfg = small_ppo_run(1024);
  cfg["ppo"]["actor"]["hidden"] = {256, 160};
  cfg["ppo"]["critic"]["hidden"] = {256, 160};
  cfg["ppo"]["rollout_steps"] = 8;
  cfg["ppo"]["minibatch_size"] = 256;
  cfg["ppo"]["log_std"] = "state_dependent";
  cfg["train"]["num_envs"] = 64;
  cfg["train"]["eval_every"] = 512;
  const std::string d1 = tmp_dir("threads1"), d2 = tmp_dir("threads2");
  atacom::set_num_threads(1);
  const auto a = train(cfg, d1);
  atacom::set_num_threads(2);
  const auto b = train(cfg, d2);
  atacom::set_num_threads(0);
  REQUIRE(a.updates == 2 * 3 * 2);
  REQUIRE(a.agent_hash == b.agent_hash);
  REQUIRE(without_wall(slurp(d1 + "/progress.csv")) == without_wall(slurp(d2 + "/progress.csv")));
  fs::remove_all(d1);
  fs::remove_all(d2);
}

TEST_CASE("ppo: a policy file acts exactly as the learner's policy", "[ppo]") {
  // Through the trainer: the final policy file, loaded from the run
  // directory, reproduces the run's final evaluation bit for bit.
  const std::string dir = tmp_dir("policy");
  json cfg = small_ppo_run(400);
  cfg["train"]["algo"] = "ppo";
  const auto s = train(cfg, dir);
  const auto policy = atacom::TrainedPolicy::load(dir);
  const atacom::RunConfig rc = atacom::resolve_run_config(cfg);
  auto eval_env =
      atacom::make_env(atacom::EnvRequest{"pendulum", rc.train.eval_episodes, atacom::SafetyLayer::None, rc.env});
  const atacom::EvalResult ev = atacom::evaluate(*eval_env, *policy, rc.train.eval_episodes, uint64_t(rc.train.seed),
                                                 rc.train.eval_deterministic);
  REQUIRE(ev.return_mean == s.final_eval.return_mean);
  fs::remove_all(dir);
  // Directly: sampled and mean actions of a saved and reloaded policy equal
  // the learner's, with normalisation statistics that moved and both log-std modes.
  for (const bool dependent : {false, true}) {
    PpoConfig c = tiny_config();
    if (dependent) c.log_std = atacom::LogStdMode::StateDependent;
    Bench b("pendulum", 8, c);
    for (int k = 0; k < 20; ++k) b.step();  // two updates and a partial rollout
    std::stringstream file;
    b.learner->policy().save(file);
    atacom::PpoPolicy loaded(b.env->spec(), c);
    loaded.load(file);
    for (const bool det : {true, false}) {
      std::vector<Rng> r1 = b.rngs, r2 = b.rngs;
      std::vector<double> a1(8), a2(8);
      b.learner->policy().act(b.obs.data(), 8, det, r1.data(), a1.data());
      loaded.act(b.obs.data(), 8, det, r2.data(), a2.data());
      REQUIRE(a1 == a2);
    }
  }
}

// Pendulum swing-up: mean deterministic eval return >= -200 over 10 episodes
// (the SAC learning test's threshold, tests/test_sac.cpp), for at least 4 of
// 5 seeds, at the final evaluation of the shipped config
// configs/pendulum_ppo.json.
TEST_CASE("ppo learns Pendulum: eval return >= -200 for 4 of 5 seeds", "[learning]") {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string cfg_path =
      (fs::path(__FILE__).parent_path().parent_path() / "configs" / "pendulum_ppo.json").string();
  std::ifstream f(cfg_path);
  INFO("config file " << cfg_path);
  REQUIRE(f.good());
  const json file = json::parse(f);
  int solved = 0;
  for (int seed = 0; seed < 5; ++seed) {
    json j = file;
    j["train"]["seed"] = seed;
    const std::string dir = tmp_dir("learn_" + std::to_string(seed));
    const auto s0 = std::chrono::steady_clock::now();
    const auto res = train(j, dir);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count();
    std::printf("pendulum ppo seed %d: final eval return %.1f +- %.1f after %lld steps, %lld updates, %.1f s\n", seed,
                res.final_eval.return_mean, res.final_eval.return_std, static_cast<long long>(res.env_steps),
                static_cast<long long>(res.updates), secs);
    solved += res.final_eval.return_mean >= -200.0;
    fs::remove_all(dir);
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("pendulum ppo: %d of 5 seeds solved in %.1f s\n", solved, total);
  REQUIRE(solved >= 4);
  REQUIRE(total < 300.0);
}
