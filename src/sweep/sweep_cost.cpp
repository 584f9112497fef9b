#include "src/sweep/sweep_cost.hpp"

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
  for (const nlohmann::json& r : rates)
    if (r.at("env") == env && r.at("safety") == safety_layer_name(layer)) return &r;
  return nullptr;
}

}  // namespace

double estimate_cell_seconds(const SweepCell& cell) {
  const RunConfig rc = resolve_run_config(cell.config());
  const SafetyLayer layer = run_safety_layer(rc);
  const nlohmann::json* r = rate_of(rc.train.env, layer);
  if (!r) return NAN;
  const double collect_per_s = r->at("collect_per_s").get<double>(), train_per_s = r->at("train_per_s").get<double>(),
               eval_per_s = r->at("eval_per_s").get<double>();
  // Horizons by env config (building an env per cell would cost more than the estimate is worth).
  static std::map<std::string, int> horizons;
  const std::string key = rc.train.env + rc.env.dump();
  auto h = horizons.find(key);
  if (h == horizons.end())
    h = horizons.emplace(key, make_env(EnvRequest{rc.train.env, 1, SafetyLayer::None, rc.env})->spec().horizon).first;
  const int horizon = h->second;
  const double eval_steps = double(rc.train.eval_episodes) * double(horizon > 0 ? horizon : 1000);
  if (!find_algorithm(rc.train.algo).learns()) return eval_steps / eval_per_s;
  const double steps = double(rc.train.steps);
  const double collect = std::min(steps, rc.learner.value("initial_replay", 0.0));
  const double evals = std::ceil(steps / double(rc.train.eval_every));
  return collect / collect_per_s + (steps - collect) / train_per_s + evals * eval_steps / eval_per_s;
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
