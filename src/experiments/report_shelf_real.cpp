// ShelfEnvReal rows of the sweep report (report_shelf_real.hpp).
#include "src/experiments/report_shelf_real.hpp"

#include <filesystem>
#include <memory>
#include <set>

#include "atacom/env_registry.hpp"
#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"
#include "envs/arm/arm_attractor.hpp"
#include "src/core/config_json.hpp"
#include "src/safety/cbf_env.hpp"
#include "train/algorithms.hpp"

namespace fs = std::filesystem;

namespace atacom {

namespace {

// The shelf env config a run trained with: defaults under its config.json's env section.
ArmEnvConfig run_env_config(const nlohmann::json& env_section) {
  ArmEnvConfig ec = default_arm_env_config(ArmTask::Shelf);
  from_json(merge_config_strict(nlohmann::json(ec), env_section), ec);
  return ec;
}

// The protocol through the layer a run trained with, with that layer's
// parameters from the run's config (CBF's gamma; absent: the layer's default).
ShelfRealConfig run_protocol(ShelfRealConfig c, SafetyLayer layer, const nlohmann::json& layer_params) {
  c.layer = parse_shelf_real_layer(layer.name());
  if (c.layer == ShelfRealLayer::Cbf) c.cbf_gamma = layer_params.value("gamma", kCbfDefaultGamma);
  return c;
}

}  // namespace

ShelfRealSection shelf_real_section(const ReportData& d) {
  ShelfRealSection s;
  s.protocol = default_shelf_real_config();
  std::set<std::string> attractors_done;
  for (const ReportRun& r : d.runs) {
    if (!r.finished || r.cell.env != "shelf") continue;
    const Algorithm& alg = find_algorithm(r.cell.algo);
    if (alg.source == ActionSource::Random || alg.source == ActionSource::Zero) continue;
    if (alg.source == ActionSource::Attractor && !attractors_done.insert(alg.name).second) continue;
    ShelfRealRun row;
    row.run = &r;
    row.safety = alg.safety.name();
    const std::string dir = (fs::path(d.opts.dir) / r.cell.run_dir()).string();
    if (alg.learns() && !fs::exists(fs::path(dir) / run_policy_file(RunPolicy::Final))) {
      row.skipped = std::string("no ") + run_policy_file(RunPolicy::Final) + " in the run directory";
    } else {
      try {
        if (alg.learns()) {
          auto tp = TrainedPolicy::load(dir, RunPolicy::Final);
          row.result = evaluate_shelf_real(run_env_config(tp->config().env),
                                           run_protocol(s.protocol, alg.safety, tp->config().safety), *tp);
        } else {
          const nlohmann::json cfg = read_json_file((fs::path(dir) / "config.json").string(), "run config");
          const ArmEnvConfig ec = run_env_config(cfg.value("env", nlohmann::json::object()));
          ArmAttractorPolicy la(ec);
          row.result = evaluate_shelf_real(
              ec, run_protocol(s.protocol, alg.safety, cfg.value(alg.safety.name(), nlohmann::json::object())), la);
        }
      } catch (const std::exception& e) {
        row.skipped = e.what();
      }
    }
    s.runs.push_back(row);
  }
  for (const std::string& algo : d.algos) {
    const Algorithm& alg = find_algorithm(algo);
    ShelfRealAlgo a;
    a.algo = algo;
    a.safety = alg.safety.name();
    a.attractor = alg.source == ActionSource::Attractor;
    for (const ShelfRealRun& row : s.runs) {
      if (row.run->cell.algo != algo || !row.skipped.empty()) continue;
      ++a.n;
      for (int t = 0; t < 2 && t < int(row.result.targets.size()); ++t) {
        a.success[t].push_back(row.result.targets[t].success_rate);
        a.error[t].push_back(row.result.targets[t].final_error_mean);
      }
      a.collisions.push_back(row.result.total_collisions);
      a.violation_steps += row.result.max_constraint_violations;
    }
    if (a.n > 0) s.algos.push_back(a);
  }
  return s;
}

int ShelfRealAlgo::total_collisions() const {
  int n = 0;
  for (double c : collisions) n += int(c);
  return n;
}

std::string shelf_real_stream(const std::string& algo, const std::string& what) { return "shelf_real/" + algo + "/" + what; }

}  // namespace atacom
