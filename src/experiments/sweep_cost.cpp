#include "src/experiments/sweep_cost.hpp"

#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"
#include "src/core/data_dir.hpp"
#include "train/algorithms.hpp"

namespace atacom {

namespace {

const nlohmann::json& rates_file() {
  static const nlohmann::json j = read_json_file(data_file("sweep_rates.json"), "sweep rates");
  return j;
}

const nlohmann::json* rate_of(const std::string& env, SafetyLayer layer) {
  const nlohmann::json& rates = rates_file().at("rates");
  // CBF solves SafeLayer's QP with another right-hand side: SafeLayer's rate stands in for it.
  std::string name = safety_layer_name(layer);
  if (name == "cbf") name = "safelayer";
  for (const nlohmann::json& r : rates)
    if (r.at("env") == env && r.at("safety") == name) return &r;
  return nullptr;
}

struct EnvShape {
  int horizon = 0, obs = 0, act = 0;
};

// Horizon and sizes by env config (building an env per cell would cost more than the estimate is worth).
const EnvShape& env_shape(const RunConfig& rc) {
  static std::map<std::string, EnvShape> shapes;
  const std::string key = rc.train.env + rc.env.dump();
  auto h = shapes.find(key);
  if (h == shapes.end()) {
    const auto env = make_env(EnvRequest{rc.train.env, 1, SafetyLayer::None, rc.env});
    h = shapes.emplace(key, EnvShape{env->spec().horizon, env->spec().obs_dim, env->spec().act_dim}).first;
  }
  return h->second;
}

double mlp_weights(int in, const nlohmann::json& net, int out) {
  double w = 0;
  int prev = in;
  for (const nlohmann::json& h : net.at("hidden")) w += double(prev) * h.get<int>(), prev = h.get<int>();
  return w + double(prev) * out;
}

// The learning work per env step, in weight x sample units of a forward pass
// (a backward pass costs about two). SAC, per update and sample: the twin
// critics forward and backward (6 Wc), their targets and the next action
// (2 Wc + Wa), the actor's loss through the twins (3 Wa + 4 Wc); the
// Lagrangian variant adds twin cost critics and their targets (8 Wc). PPO,
// per env step: each epoch passes the sample forward and backward through the
// actor and the value network (a second one for PPO-Lag), the rollout once.
double learn_work_per_step(const std::string& learner, const nlohmann::json& cfg, const EnvShape& s) {
  const bool lag = learner.size() > 4 && learner.compare(learner.size() - 4, 4, "-lag") == 0;
  if (learner.rfind("ppo", 0) == 0) {
    const double wa = mlp_weights(s.obs, cfg.at("actor"), s.act),
                 wv = mlp_weights(s.obs, cfg.at("critic"), 1) * (lag ? 2 : 1);
    return cfg.at("epochs").get<double>() * 3 * (wa + wv) + (wa + wv);
  }
  const double wa = mlp_weights(s.obs, cfg.at("actor"), 2 * s.act), wc = mlp_weights(s.obs + s.act, cfg.at("critic"), 1);
  return cfg.at("updates_per_step").get<double>() * cfg.at("batch_size").get<double>() *
         (4 * wa + 12 * wc + (lag ? 8 * wc : 0));
}

}  // namespace

double estimate_cell_seconds(const SweepCell& cell) {
  const RunConfig rc = resolve_run_config(cell.config());
  const SafetyLayer layer = run_safety_layer(rc);
  const nlohmann::json* r = rate_of(rc.train.env, layer);
  if (!r) return NAN;
  const double collect_per_s = r->at("collect_per_s").get<double>(), train_per_s = r->at("train_per_s").get<double>(),
               eval_per_s = r->at("eval_per_s").get<double>();
  const EnvShape& shape = env_shape(rc);
  const double eval_steps = double(rc.train.eval_episodes) * double(shape.horizon > 0 ? shape.horizon : 1000);
  const Algorithm& algo = find_algorithm(rc.train.algo);
  if (!algo.learns()) return eval_steps / eval_per_s;
  // The rates' runs: SAC under the layer with the env's paper-preset settings.
  // A learner's update seconds per env step are theirs scaled by its work
  // per env step (updates per step, batch, network sizes, epochs).
  static std::map<std::string, double> seconds_per_work;
  const std::string rate_key = rc.train.env + "/" + safety_layer_name(layer);
  auto sw = seconds_per_work.find(rate_key);
  if (sw == seconds_per_work.end()) {
    const std::string sac = algorithm_for(ActionSource::Learner, "sac", layer).name;
    const RunConfig ref = resolve_run_config(nlohmann::json{{"train", {{"env", rc.train.env}, {"algo", sac}}}});
    const double update_s = std::max(0.0, 1.0 / train_per_s - 1.0 / collect_per_s);
    sw = seconds_per_work.emplace(rate_key, update_s / learn_work_per_step("sac", ref.learner, shape)).first;
  }
  const double steps = double(rc.train.steps);
  const double collect = std::min(steps, rc.learner.value("initial_replay", 0.0));
  const double evals = std::ceil(steps / double(rc.train.eval_every));
  const double learn_s = sw->second * learn_work_per_step(algo.learner, rc.learner, shape);
  return steps / collect_per_s + (steps - collect) * learn_s + evals * eval_steps / eval_per_s;
}

SweepCost estimate_sweep_cost(const std::vector<SweepCell>& cells, const std::vector<size_t>& which) {
  SweepCost c;
  const nlohmann::json& f = rates_file();
  c.source = f.value("cpu", std::string("?")) + ", " + f.value("date", std::string("?")) + ": " +
             f.value("command", std::string("?"));
  // A cell's seeds differ in train.seed only, which no rate depends on: one
  // estimate per (env, algo) pair (100,000 cells would resolve 100,000 configs).
  std::map<std::tuple<const nlohmann::json*, std::string, std::string, int64_t, int, std::string>, double> pair_seconds;
  for (size_t k : which) {
    const SweepCell& cell = cells.at(k);
    const auto key = std::make_tuple(cell.base.get(), cell.env, cell.algo, cell.steps, cell.num_envs, cell.preset);
    auto it = pair_seconds.find(key);
    if (it == pair_seconds.end()) it = pair_seconds.emplace(key, estimate_cell_seconds(cell)).first;
    const double s = it->second;
    if (std::isfinite(s)) c.run_seconds += s;
    else ++c.unknown;
  }
  return c;
}

SweepCost estimate_sweep_cost(const std::vector<SweepCell>& cells) {
  std::vector<size_t> all(cells.size());
  for (size_t k = 0; k < cells.size(); ++k) all[k] = k;
  return estimate_sweep_cost(cells, all);
}

}  // namespace atacom
