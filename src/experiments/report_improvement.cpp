#include "src/experiments/report_improvement.hpp"

#include <algorithm>
#include <cmath>

#include "train/algorithms.hpp"

namespace atacom {

std::string main_algorithm(const ReportData& d) {
  for (const char* m : {"atacom-sac", "atacom-ppo"})
    for (const auto& a : d.algos)
      if (a == m) return m;
  return "";
}

std::vector<std::pair<std::string, std::string>> improvement_pairs(const ReportData& d) {
  std::vector<std::pair<std::string, std::string>> out;
  const std::string main = main_algorithm(d);
  if (main.empty()) return out;
  for (const auto& base : d.algos)
    if (base != main) out.emplace_back(main, base);
  for (const auto& algo : d.algos) {
    const Algorithm& a = find_algorithm(algo);
    if (algo == main || a.safety != SafetyLayer::Atacom) continue;
    const std::string& bare = algorithm_for(a.source, a.learner, SafetyLayer::None).name;
    if (std::find(d.algos.begin(), d.algos.end(), bare) != d.algos.end()) out.emplace_back(algo, bare);
  }
  return out;
}

namespace {

Improvement computed(const ReportData& d, const std::string& env, const ReportMetric& m, const std::string& algo,
                     const std::string& base, const std::string& stream) {
  const std::vector<double> x = metric_values(d, env, algo, m.key), y = metric_values(d, env, base, m.key);
  Improvement r;
  r.n_algo = x.size();
  r.n_baseline = y.size();
  if (x.size() < kMinSeedsForInterval || y.size() < kMinSeedsForInterval) return r;
  r.p = probability_of_improvement(x, y, m.higher_better);
  r.ci = bootstrap_improvement_ci(x, y, m.higher_better, d.opts.resamples, d.opts.seed, bootstrap_stream(stream));
  return r;
}

}  // namespace

Improvement improvement(const ReportData& d, const std::string& env, const ReportMetric& m, const std::string& algo,
                        const std::string& base) {
  const std::string main = main_algorithm(d);
  // The main algorithm keeps the streams it had before the other pairs were added.
  const auto stream = [&](const std::string& a, const std::string& b) {
    return env + "/" + m.key + "/improvement/" + b + (a == main ? "" : "/by/" + a);
  };
  const auto pairs = improvement_pairs(d);
  const auto has = [&](const std::string& a, const std::string& b) {
    return std::find(pairs.begin(), pairs.end(), std::make_pair(a, b)) != pairs.end();
  };
  if (has(algo, base)) return computed(d, env, m, algo, base, stream(algo, base));
  if (has(base, algo)) {
    Improvement r = computed(d, env, m, base, algo, stream(base, algo));
    std::swap(r.n_algo, r.n_baseline);
    r.p = 1 - r.p;  // Mann-Whitney: every pair's 1 / 0.5 / 0 mirrors, resample by resample
    r.ci = {1 - r.ci.high, 1 - r.ci.low};
    return r;
  }
  return computed(d, env, m, algo, base, env + "/" + m.key + "/claim/" + algo + "/over/" + base);
}

}  // namespace atacom
