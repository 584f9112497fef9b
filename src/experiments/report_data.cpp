// Reading a sweep directory for the report: every cell of its spec, finished or not.
#include "src/experiments/report_data.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"
#include "src/experiments/sweep_state.hpp"

namespace fs = std::filesystem;

namespace atacom {

const std::vector<ReportMetric>& report_metrics() {
  static const std::vector<ReportMetric> m = {
      {"eval_discounted_return_mean", "discounted return (final policy)", true, true},
      {"final_distance", "final distance [m] (final policy)", false, true},
      {"train_terminations", "early terminations (training)", false, true},
      {"train_avg_episode_steps", "average episode steps (training)", true, true},
      {"avg_episode_steps", "episode steps (final policy)", true, false},
      {"train_collisions", "collisions (training)", false, true},
      {"train_violations", "constraint-violating steps (training)", false, true},
      {"train_cost", "cost steps (training)", false, true},
      {"eval_cost_mean", "episode cost (final policy)", false, true},
      {"eval_return_mean", "return (final policy)", true, false},
      {"best.eval_return_mean", "return (best evaluation)", true, false},
      {"best.eval_discounted_return_mean", "discounted return (best evaluation)", true, false},
      {"best.final_distance", "final distance [m] (best evaluation)", false, false},
      {"time_to_target_s", "time to target [s] (wall, evaluations included)", false, false, true},
      {"steps_to_target", "env steps to target", false, false, true},
      {"updates_to_target", "updates to target", false, false, true},
      {"train_cost_to_target", "training collisions + violating steps to target", false, false, true},
      // HRI-Sim (absent elsewhere): the paper's "episodes in which a spill happens", at both angles.
      {"spills", "episodes with a spill at 25 deg (final policy)", false, false},
      {"spills_15", "episodes with a spill at 15 deg (final policy)", false, false},
      {"min_human_distance", "closest approach to the human [m] (final policy)", true, false},
  };
  return m;
}

const ReportMetric* find_report_metric(const std::string& key) {
  for (const ReportMetric& m : report_metrics())
    if (key == m.key) return &m;
  return nullptr;
}

std::optional<double> metric_value(const nlohmann::json& summary, const std::string& key) {
  const nlohmann::json* j = &summary;
  std::string k = key;
  if (k.rfind("best.", 0) == 0) {
    if (!summary.contains("best") || !summary["best"].is_object()) return std::nullopt;
    j = &summary["best"];
    k = k.substr(5);
  }
  if (!j->contains(k) || !(*j)[k].is_number()) return std::nullopt;
  const double v = (*j)[k].get<double>();
  if (!std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<double> censored_value(const nlohmann::json& summary, const std::string& key) {
  if (const auto v = metric_value(summary, key)) return v;
  const bool has_target = summary.contains("target") && summary["target"].is_object();
  if (has_target && summary.contains(key) && summary[key].is_null()) return std::numeric_limits<double>::infinity();
  return std::nullopt;
}

std::vector<double> metric_values(const ReportData& d, const std::string& env, const std::string& algo,
                                  const std::string& key) {
  const ReportMetric* m = find_report_metric(key);
  const bool censored = m && m->censored;
  std::vector<double> out;
  for (const ReportRun& r : d.runs)
    if (r.finished && r.cell.env == env && r.cell.algo == algo)
      if (const auto v = censored ? censored_value(r.summary, key) : metric_value(r.summary, key)) out.push_back(*v);
  return out;
}

namespace {

// The curves of a run's progress.csv (a regular file below the sweep
// directory, at most kMaxProgressBytes); a missing file gives none.
void read_curves(const std::string& dir, const std::string& rel, ReportRun& r) {
  std::string why;
  const std::optional<std::string> text = read_below(dir, rel, kMaxProgressBytes, &why);
  if (!text) {
    if (why == "does not exist") return;
    throw std::invalid_argument("cannot read progress file '" + printable_text(dir + "/" + rel) + "': it " + why);
  }
  std::istringstream f(*text);
  std::string line;
  if (!std::getline(f, line)) return;
  std::vector<std::string> cols;
  {
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) cols.push_back(c);
  }
  auto col = [&](const char* name) {
    for (size_t i = 0; i < cols.size(); ++i)
      if (cols[i] == name) return int(i);
    return -1;
  };
  const int cs = col("env_steps"), cr = col("eval_return_mean"), cd = col("final_distance"), cc = col("train_cost");
  if (cs < 0 || cr < 0) return;
  while (std::getline(f, line)) {
    std::vector<double> v;
    // Every cell, the empty last one included ("" reads as NaN: a target not met yet; "nan" too).
    for (size_t at = 0;;) {
      const size_t comma = line.find(',', at);
      const std::string c = line.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
      v.push_back(c.empty() ? NAN : std::strtod(c.c_str(), nullptr));
      if (comma == std::string::npos) break;
      at = comma + 1;
    }
    if (int(v.size()) != int(cols.size())) continue;
    r.steps.push_back(v[size_t(cs)]);
    r.eval_return.push_back(v[size_t(cr)]);
    if (cd >= 0) r.final_distance.push_back(v[size_t(cd)]);
    if (cc >= 0) r.train_cost.push_back(v[size_t(cc)]);
  }
}

}  // namespace

ReportData load_report_data(const ReportOptions& opts) {
  ReportData d;
  d.opts = opts;
  const SweepSpec spec = load_sweep_spec(opts.dir);
  d.envs = spec.envs;
  d.algos = spec.algos;
  for (const SweepCell& c : sweep_cells(spec)) {
    if (!opts.seeds.empty() && !std::binary_search(opts.seeds.begin(), opts.seeds.end(), c.seed)) continue;
    ReportRun r;
    r.cell = c;
    const CellStatus st = cell_status(opts.dir, c);
    r.state = st.state;
    r.log = cell_log_path(c);
    r.finished = st.state == "done";
    if (r.finished) {
      r.summary = read_json_below(opts.dir, c.run_dir() + "/summary.json", "summary file", kMaxSummaryBytes);
      read_curves(opts.dir, c.run_dir() + "/progress.csv", r);
    }
    d.runs.push_back(std::move(r));
  }
  return d;
}

}  // namespace atacom
