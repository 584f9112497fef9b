// The adversary (train/adversary.hpp): its shaped reward is what the header
// says, it refuses envs without rows, and on an unprotected env it finds
// far more ground-truth collisions than random actions in the same steps.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/trainer.hpp"
#include "train/adversary.hpp"
#include "train/rollout.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

TEST_CASE("adversary: reward = min(max_r c_r / s_r, cap) + bonus at a collision", "[adversary]") {
  const int N = 3;
  auto env = make_env(EnvRequest{"nav", N});
  env->seed(4);
  const EnvSpec& spec = env->spec();
  const int k = spec.num_constraints, ni = int(spec.info_names.size());
  AdversaryConfig cfg = default_adversary_config();
  cfg.sac.actor.hidden = cfg.sac.critic.hidden = {8};
  LearnerContext ctx{&spec, N, 4, &env->buffers()};
  AdversaryLearner adv(ctx, cfg);
  // row scales: mean |c| of the first states, floored
  for (int r = 0; r < k; ++r) {
    double m = 0;
    for (int i = 0; i < N; ++i) m += std::abs(env->buffers().constraints[size_t(i) * k + r]) / N;
    CHECK(adv.row_scale()[size_t(r)] == Approx(std::max(cfg.scale_floor, m)));
  }
  EnvBuffers after = env->buffers();
  const std::vector<float> obs = after.obs;
  const std::vector<double> act(size_t(N) * 2, 0.0);
  const std::vector<double>& s = adv.row_scale();
  for (int i = 0; i < N; ++i)
    for (int r = 0; r < k; ++r) after.constraints[size_t(i) * k + r] = -0.5 * s[size_t(r)];
  after.constraints[1] = -0.1 * s[1];                   // env 0: row 1 closest
  after.constraints[size_t(k) + 4] = 3.0 * s[4];        // env 1: row 4 far beyond its boundary: capped
  after.info[size_t(2) * ni + 0] = 1.0f;                // env 2: a ground-truth collision ("collision")
  REQUIRE(spec.info_names[0] == "collision");
  adv.observe(obs.data(), act.data(), after);
  CHECK(adv.last_reward()[0] == Approx(-0.1));
  CHECK(adv.last_reward()[1] == Approx(cfg.reward_cap));
  CHECK(adv.last_reward()[2] == Approx(-0.5 + cfg.collision_bonus));
  CHECK(adv.max_constraint() == Approx(3.0 * s[4]));
  const json sum = adv.summary();
  CHECK(sum["adversary"]["max_constraint_row"] == spec.constraint_names[4]);
  CHECK(sum["adversary"]["worst"].size() == 3);  // one running episode per env
  CHECK(sum["adversary"]["worst"][0]["row"] == spec.constraint_names[4]);
  CHECK(sum["adversary"]["worst"][0]["constraints"].size() == size_t(k));
  CHECK(sum["adversary"]["worst"][0]["obs"].size() == size_t(spec.obs_dim));
  // no rows, nothing to attack
  auto pend = make_env(EnvRequest{"pendulum", 1});
  pend->seed(0);
  LearnerContext pc{&pend->spec(), 1, 0, &pend->buffers()};
  CHECK_THROWS_WITH(AdversaryLearner(pc, cfg), Catch::Contains("nothing to attack"));
  // config: strict, the nested SAC section laid over the adversary's own defaults
  const AdversaryConfig c2 = json{{"sac", {{"lr_actor", 5e-4}}}, {"collision_bonus", 3.0}}.get<AdversaryConfig>();
  CHECK(c2.sac.lr_actor == 5e-4);
  CHECK(c2.sac.actor.hidden == std::vector<int>{64, 64});
  CHECK(c2.collision_bonus == 3.0);
  CHECK_THROWS_WITH((json{{"bonus", 1.0}}.get<AdversaryConfig>()), Catch::Contains("adversary.bonus"));
  CHECK_THROWS_WITH((json{{"sac", {{"lr_actr", 1.0}}}}.get<AdversaryConfig>()), Catch::Contains("lr_actr"));
}

TEST_CASE("adversary: on unprotected TableEnv it finds far more collisions than random actions", "[adversary][slow]") {
  // 8000 env steps, 4 envs, seed 2 (about 9 s on 2 busy cores). Both end
  // episodes at the first contact, so the largest constraint value is capped
  // by one step's overshoot for both; the attack shows in how often it gets
  // there: ground-truth collisions per env step.
  const std::string dir = (fs::temp_directory_path() / ("atacom_adv_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  json cfg = {{"train", {{"env", "table"}, {"algo", "attack"}, {"steps", 8000}, {"num_envs", 4},
                         {"eval_every", 8000}, {"eval_episodes", 2}, {"seed", 2}}}};
  TrainOptions o;
  o.out_dir = dir;
  const json s = run_training(resolve_run_config(cfg), o).summary;
  const json a = attack_result(s);
  RolloutConfig rc;
  rc.env = "table";
  rc.policy = "random";
  rc.safety = SafetyLayer::None;
  rc.steps = 8000;
  rc.envs = 4;
  rc.seed = 2;
  const json r = run_rollout(rc);
  INFO("adversary: " << a.dump() << "\nrandom: " << r.dump());
  CHECK(a["steps"] == 8000);
  CHECK(a["collisions"].get<double>() >= 20);
  CHECK(a["collisions"].get<double>() >= 5 * std::max(1.0, r["collisions"].get<double>()));
  CHECK(a["max_constraint"].get<double>() > 0.0);
  CHECK(!a["worst"].empty());
  fs::remove_all(dir);
}
