// atacom report: the numbers of summary.csv, prob_improvement.csv and
// final_vs_best.csv against a direct computation from the run files, known
// values of the statistics, and missing/failed runs listed.
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "src/experiments/report.hpp"
#include "src/experiments/report_stats.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/csv_rows.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

std::vector<std::map<std::string, std::string>> read_csv(const std::string& p) { return csv_rows::read(p); }

// Independent reference statistics: sorted copies and textbook formulas.
double ref_quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const size_t i = size_t(pos);
  return i + 1 < v.size() ? v[i] * (1 - (pos - double(i))) + v[i + 1] * (pos - double(i)) : v[i];
}
double ref_iqm(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t k = v.size() / 4;
  double s = 0;
  for (size_t i = k; i + k < v.size(); ++i) s += v[i];
  return s / double(v.size() - 2 * k);
}
uint64_t fnv_text(const std::string& s) {
  uint64_t h = 14695981039346656037ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}
std::pair<double, double> ref_ci(const std::vector<double>& v, int R, uint64_t seed, const std::string& key) {
  Rng rng(seed, fnv_text(key));
  std::vector<double> st;
  for (int r = 0; r < R; ++r) {
    std::vector<double> s;
    for (size_t i = 0; i < v.size(); ++i) s.push_back(v[rng.below(v.size())]);
    st.push_back(ref_iqm(s));
  }
  return {ref_quantile(st, 0.025), ref_quantile(st, 0.975)};
}

double ref_pi(const std::vector<double>& x, const std::vector<double>& y, bool higher) {
  double wins = 0;
  for (double a : x)
    for (double b : y) wins += (higher ? a > b : a < b) ? 1.0 : a == b ? 0.5 : 0.0;
  return wins / double(x.size() * y.size());
}
std::pair<double, double> ref_pi_ci(const std::vector<double>& x, const std::vector<double>& y, bool higher, int R,
                                    uint64_t seed, const std::string& key) {
  Rng rng(seed, fnv_text(key));
  std::vector<double> st;
  for (int r = 0; r < R; ++r) {
    std::vector<double> sx, sy;
    for (size_t i = 0; i < x.size(); ++i) sx.push_back(x[rng.below(x.size())]);
    for (size_t i = 0; i < y.size(); ++i) sy.push_back(y[rng.below(y.size())]);
    st.push_back(ref_pi(sx, sy, higher));
  }
  return {ref_quantile(st, 0.025), ref_quantile(st, 0.975)};
}

bool close(const std::string& text, double want) {
  const double got = std::stod(text);
  return std::abs(got - want) <= 1e-10 * std::max(1.0, std::abs(want));
}

// The run files of a sweep whose cells are two levels: `weaker` worse than
// every other algorithm on every metric; seed s shifts the return by s and
// the final distance by 0.01 s (nothing at seed 0).
void write_two_level_runs(const std::string& dir, const SweepSpec& spec, const std::string& weaker) {
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const double a = c.algo == weaker ? 0 : 1, s = c.seed;
    const json sm = {{"env_steps", 3000}, {"eval_return_mean", -300 + 40 * a + s}, {"eval_discounted_return_mean", -90 + a},
                     {"final_distance", 0.9 - 0.5 * a + 0.01 * s}, {"train_terminations", 10 - 10 * a},
                     {"avg_episode_steps", 400}, {"train_avg_episode_steps", 300}, {"train_collisions", 31 * (1 - a)},
                     {"train_violations", 50 * (1 - a)},
                     {"best", {{"eval_return_mean", -300 + 40 * a}, {"eval_discounted_return_mean", -90},
                               {"final_distance", 0.9 - 0.5 * a}, {"env_steps", 1000}}}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance\n"
                                        << "1000,0,0.1,-400,1\n3000,0,0.2,-300,0.5\n";
  }
}

}  // namespace

TEST_CASE("report: statistics at known values", "[report]") {
  REQUIRE(quantile({1, 2, 3, 4}, 0.25) == Approx(1.75));  // numpy.percentile(.., 25)
  REQUIRE(quantile({4, 1, 3, 2}, 0.5) == Approx(2.5));
  REQUIRE(iqm({1, 2, 3, 4, 5, 6, 7, 8}) == Approx(4.5));  // drops 2 at each end
  REQUIRE(iqm({1, 2, 3, 100}) == Approx(2.5));
  REQUIRE(iqm({5, 1, 9}) == Approx(5.0));                 // n = 3: floor(3/4) = 0, the mean
  REQUIRE(sample_std({1, 2, 3, 4}) == Approx(std::sqrt(5.0 / 3.0)));
  REQUIRE(probability_of_improvement({3, 4}, {1, 3}, true) == Approx(0.875));
  REQUIRE(probability_of_improvement({3, 4}, {1, 3}, false) == Approx(0.125));
  const Interval a = bootstrap_iqm_ci({1, 2, 3, 4, 5}, 1000, 7, 9), b = bootstrap_iqm_ci({1, 2, 3, 4, 5}, 1000, 7, 9);
  REQUIRE((a.low == b.low && a.high == b.high));  // seeded
  REQUIRE((a.low >= 1 && a.low <= 3 && a.high >= 3 && a.high <= 5));
  const Interval one = bootstrap_iqm_ci({2.5}, 100, 0, 0);
  REQUIRE((one.low == 2.5 && one.high == 2.5));
}

TEST_CASE("report: the numbers equal a direct computation from the run files", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const json spec_json = json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac", "la", "la-atacom"],
                                        "seeds": [0, 1, 2, 3, 4, 5], "steps": 3000})");
  const SweepSpec spec = parse_sweep_spec(spec_json);
  save_or_check_spec(dir, spec);
  // Synthetic run files: values that differ per cell and seed.
  std::map<std::string, std::map<std::string, std::vector<double>>> want;  // algo -> key -> values (seed order)
  for (const SweepCell& c : sweep_cells(spec)) {
    if (c.algo == "sac" && c.seed == 5) continue;  // never ran: missing
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    if (c.algo == "atacom-sac" && c.seed == 4) {  // failed: a state file says so, no summary
      write_cell_state(dir, c, {{"state", "failed"}, {"exit_code", 3}, {"attempts", 1}});
      continue;
    }
    const double s = double(c.seed), a = c.algo == "sac" ? 0 : c.algo == "atacom-sac" ? 1 : c.algo == "la" ? 2 : 3;
    json sm = {{"env_steps", c.learns ? 3000 : 0},
               {"eval_discounted_return_mean", -100 + 17 * a - 3 * s * s + 0.25 * s},
               {"eval_return_mean", -300 + 40 * a + 7 * s},
               {"final_distance", 0.1 + 0.05 * s + 0.3 * (2 - a)},
               {"train_terminations", c.learns ? (2 - a) * 10 + s : 0},
               {"avg_episode_steps", 500 - 10 * s},  // the final evaluation's: not the paper's metric
               {"train_avg_episode_steps", 300 + 20 * a - 9 * s + (s == 1 ? 0.5 : 0)},
               {"train_collisions", a == 0 ? s : 0},
               {"train_violations", a == 0 ? 3 * s + 1 : 0},
               {"best", {{"eval_return_mean", -300 + 40 * a + 7 * s + (s == 2 ? 200 : 0)},
                         {"eval_discounted_return_mean", -90 + s},
                         {"final_distance", 0.1 + 0.05 * s + 0.3 * (2 - a) - (s == 3 ? 0.5 : 0)},
                         {"env_steps", 1000}}}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance\n"
                                        << "1000,0,0.1," << -400 + s << ",1\n3000,0,0.2," << -300 + s << ",0.5\n";
    for (const char* k : {"eval_discounted_return_mean", "final_distance", "train_terminations", "train_avg_episode_steps",
                          "avg_episode_steps", "train_collisions", "train_violations", "eval_return_mean"})
      want[c.algo][k].push_back(sm[k].get<double>());
    for (const char* k : {"eval_return_mean", "eval_discounted_return_mean", "final_distance"})
      want[c.algo][std::string("best.") + k].push_back(sm["best"][k].get<double>());
  }
  ReportOptions o;
  o.dir = dir;
  o.resamples = 500;
  o.seed = 11;
  const ReportResult res = write_report(o);
  REQUIRE(res.finished == 22);
  REQUIRE(res.missing == std::vector<std::string>{"table-sac-seed5", "table-atacom-sac-seed4"});

  const auto rows = read_csv(dir + "/report/summary.csv");
  size_t checked = 0;
  for (const auto& r : rows) {
    INFO(r.at("algo") << " " << r.at("metric"));
    REQUIRE(r.at("env") == "table");
    const std::vector<double>& v = want.at(r.at("algo")).at(r.at("metric"));
    double m = 0, ss = 0;
    for (double x : v) m += x / double(v.size());
    for (double x : v) ss += (x - m) * (x - m);
    REQUIRE(std::stoul(r.at("n")) == v.size());
    REQUIRE(close(r.at("mean"), m));
    REQUIRE(close(r.at("std"), std::sqrt(ss / double(v.size() - 1))));
    REQUIRE(close(r.at("median"), ref_quantile(v, 0.5)));
    REQUIRE(close(r.at("q1"), ref_quantile(v, 0.25)));
    REQUIRE(close(r.at("q3"), ref_quantile(v, 0.75)));
    REQUIRE(close(r.at("iqm"), ref_iqm(v)));
    const auto ci = ref_ci(v, 500, 11, "table/" + r.at("algo") + "/" + r.at("metric"));
    REQUIRE(close(r.at("iqm_ci_low"), ci.first));
    REQUIRE(close(r.at("iqm_ci_high"), ci.second));
    ++checked;
  }
  REQUIRE(checked == 4 * 11);

  const auto pis = read_csv(dir + "/report/prob_improvement.csv");
  // atacom-sac against the 3 others, then the other source through ATACOM against itself without: la-atacom vs la.
  REQUIRE(pis.size() == 4 * 6);
  for (const auto& p : pis) {
    INFO(p.at("algo") << " " << p.at("baseline") << " " << p.at("metric"));
    const std::string algo = p.at("algo");
    REQUIRE((algo == "atacom-sac" || (algo == "la-atacom" && p.at("baseline") == "la")));
    const std::string k = p.at("metric");
    REQUIRE(k != "avg_episode_steps");  // the boxplot's episode steps are the training average
    const bool higher = k == "eval_discounted_return_mean" || k == "train_avg_episode_steps";
    const auto& x = want.at(algo).at(k);
    const auto& y = want.at(p.at("baseline")).at(k);
    double wins = 0;
    for (double a : x)
      for (double b : y) wins += (higher ? a > b : a < b) ? 1.0 : a == b ? 0.5 : 0.0;
    REQUIRE(p.at("n_algo") == std::to_string(x.size()));
    REQUIRE(close(p.at("p_improvement"), wins / double(x.size() * y.size())));
    const auto pci = ref_pi_ci(x, y, higher, 500, 11,
                               "table/" + k + "/improvement/" + p.at("baseline") + (algo == "atacom-sac" ? "" : "/by/" + algo));
    REQUIRE(close(p.at("p_ci_low"), pci.first));
    REQUIRE(close(p.at("p_ci_high"), pci.second));
    REQUIRE(std::stod(p.at("p_ci_low")) <= std::stod(p.at("p_improvement")));
    REQUIRE(std::stod(p.at("p_improvement")) <= std::stod(p.at("p_ci_high")));
  }

  // Seed 2 fell 200 below its best return, seed 3 ended 0.5 m further than its best distance.
  for (const auto& f : read_csv(dir + "/report/final_vs_best.csv"))
    REQUIRE(f.at("drop") == ((f.at("seed") == "2" || f.at("seed") == "3") ? "1" : "0"));
  const auto missing = read_csv(dir + "/report/missing.csv");
  REQUIRE(missing.size() == 2);
  REQUIRE(missing[1].at("state") == "failed");
  REQUIRE(missing[1].at("log") == "logs/table-atacom-sac-seed4.log");
  const std::string html = slurp(dir + "/report/index.html");
  // Nothing to fetch (the SVG namespace URI is a name, never loaded): opens from file:// offline.
  for (const char* ref : {"src=", "href=", "<script", "<link", "url("}) REQUIRE(html.find(ref) == std::string::npos);
  REQUIRE(html.find("<svg") != std::string::npos);
  REQUIRE(html.find("table-atacom-sac-seed4") != std::string::npos);
  const std::string md = slurp(dir + "/report/summary.md");
  REQUIRE(md.find("table-sac-seed5") != std::string::npos);
  REQUIRE(md.find("P(la-atacom improves on the baseline)") != std::string::npos);
  REQUIRE(html.find("<h3>P(la-atacom improves on the baseline)</h3>") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("report: time to target counts the runs that never reached it", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_ttt_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac"],
                                                          "seeds": [0, 1, 2, 3, 4], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  // sac reaches the target in 2 of 5 runs, atacom-sac in 4 of 5.
  std::map<std::string, std::vector<double>> times;  // algo -> time_to_target_s, +inf when never
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const double s = double(c.seed);
    const bool reached = c.algo == "sac" ? c.seed < 2 : c.seed != 3;
    const double t = 100 + 37 * s + (c.algo == "sac" ? 50 : 0);
    json sm = {{"env_steps", 3000}, {"final_distance", 0.1}, {"eval_return_mean", -10.0},
               {"target", {{"distance", 0.05}, {"zero_info", json::array()}}},
               {"time_to_target_s", reached ? json(t) : json(nullptr)},
               {"steps_to_target", reached ? json(1000 * (c.seed + 1)) : json(nullptr)},
               {"updates_to_target", reached ? json(900 * (c.seed + 1)) : json(nullptr)},
               {"train_cost_to_target", reached ? json(0.0) : json(nullptr)}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance,time_to_target_s\n"
                                        << "1000,0,0.1,-20,1,\n3000,0,0.2,-10,0.5,\n";
    times[c.algo].push_back(reached ? t : INFINITY);
  }
  ReportOptions o;
  o.dir = dir;
  o.resamples = 400;
  o.seed = 5;
  write_report(o);
  const auto rows = read_csv(dir + "/report/time_to_target.csv");
  REQUIRE(rows.size() == 2 * 4);  // 2 algos x the 4 censored metrics: no run dropped
  for (const auto& r : rows) {
    INFO(r.at("algo") << " " << r.at("metric"));
    REQUIRE(r.at("n") == "5");
    REQUIRE(r.at("reached") == (r.at("algo") == "sac" ? "2" : "4"));
  }
  auto row = [&](const std::string& algo, const std::string& metric) {
    for (const auto& r : rows)
      if (r.at("algo") == algo && r.at("metric") == metric) return r;
    FAIL("no row " << algo << " " << metric);
    return rows[0];
  };
  // atacom-sac: one censored run of five, trimmed off by the IQM (floor(5/4) = 1 at each end).
  const auto a = row("atacom-sac", "time_to_target_s");
  std::vector<double> fin = times["atacom-sac"];
  REQUIRE(close(a.at("iqm"), ref_iqm(fin)));  // the +inf is the top value, dropped by the trim
  REQUIRE(close(a.at("median"), ref_quantile(fin, 0.5)));
  REQUIRE(close(a.at("q3"), 248));  // the largest time: +inf lies beyond q3 here
  // sac: three of five never reached: median and IQM are "not reached", never a number made up.
  const auto b = row("sac", "time_to_target_s");
  REQUIRE(b.at("median") == "inf");
  REQUIRE(b.at("iqm") == "inf");
  REQUIRE(b.at("iqm_ci_high") == "inf");
  REQUIRE(close(b.at("q1"), 187));  // the second of 150, 187, inf, inf, inf
  // Censored runs are not in summary.csv's plain statistics (their mean would be inf).
  for (const auto& r : read_csv(dir + "/report/summary.csv")) REQUIRE(r.at("metric").find("to_target") == std::string::npos);
  // P(atacom-sac improves on sac) counts a pair of never-reached runs as equal.
  double wins = 0;
  for (double x : times["atacom-sac"])
    for (double y : times["sac"]) wins += x < y ? 1.0 : x == y ? 0.5 : 0.0;
  bool found = false;
  for (const auto& p : read_csv(dir + "/report/prob_improvement.csv"))
    if (p.at("metric") == "time_to_target_s") {
      found = true;
      REQUIRE(close(p.at("p_improvement"), wins / 25.0));
    }
  REQUIRE(found);
  const std::string md = slurp(dir + "/report/summary.md"), svg = slurp(dir + "/report/target_table.svg");
  REQUIRE(md.find("| sac | time_to_target_s | 2/5 | not reached") != std::string::npos);
  REQUIRE(md.find("censored") != std::string::npos);
  REQUIRE(svg.find("2/5 reached") != std::string::npos);
  REQUIRE(svg.find("not reached") != std::string::npos);
  REQUIRE(slurp(dir + "/report/index.html").find("target_table.svg") == std::string::npos);  // inline, not linked
  fs::remove_all(dir);
}

TEST_CASE("report: with fewer than 3 seeds a cell says 'n = 1: no interval' in grey, never an interval", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_n1_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac"],
                                                          "seeds": [0], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  write_two_level_runs(dir, spec, "sac");
  ReportOptions o;
  o.dir = dir;
  write_report(o);
  const std::string md = slurp(dir + "/report/summary.md"), html = slurp(dir + "/report/index.html");
  CHECK(md.find("n = 1: no interval") != std::string::npos);
  CHECK(md.find("n = 1: no P(improvement)") != std::string::npos);
  CHECK(md.find("At most 1 seed per cell") != std::string::npos);  // says in words what one seed shows
  CHECK(html.find("<td class=\"na\">") != std::string::npos);
  CHECK(html.find("At most 1 seed per cell") != std::string::npos);
  // The IQM cell has the value and the note, no bracketed interval; the CSVs' interval and probability fields are empty.
  CHECK(md.find("| sac | eval_return_mean | 1 | -300 (n = 1: no interval) |") != std::string::npos);
  std::istringstream csv(slurp(dir + "/report/summary.csv"));
  std::string line;
  std::getline(csv, line);
  size_t rows = 0;
  while (std::getline(csv, line)) {
    INFO(line);
    CHECK(line.size() >= 2);
    CHECK(line.substr(line.size() - 2) == ",,");
    ++rows;
  }
  CHECK(rows > 0);
  std::istringstream pcsv(slurp(dir + "/report/prob_improvement.csv"));
  std::getline(pcsv, line);
  while (std::getline(pcsv, line)) CHECK(line.back() == ',');
  fs::remove_all(dir);
}

TEST_CASE("report: a sweep without atacom-sac reports atacom-ppo's improvement on its baselines", "[report]") {
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_ppo_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["ppo", "atacom-ppo"],
                                                          "seeds": [0, 1, 2], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  write_two_level_runs(dir, spec, "ppo");
  ReportOptions o;
  o.dir = dir;
  write_report(o);
  const std::string md = slurp(dir + "/report/summary.md");
  CHECK(md.find("P(atacom-ppo improves on the baseline)") != std::string::npos);
  CHECK(md.find("atacom-sac") == std::string::npos);
  // Every seed of atacom-ppo ends closer than every seed of ppo: P = 1 on final_distance.
  bool seen = false;
  for (const auto& r : read_csv(dir + "/report/prob_improvement.csv"))
    if (r.at("metric") == "final_distance") {
      seen = true;
      CHECK(r.at("algo") == "atacom-ppo");
      CHECK(r.at("baseline") == "ppo");
      CHECK(std::stod(r.at("p_improvement")) == 1.0);
    }
  CHECK(seen);
  fs::remove_all(dir);
}

TEST_CASE("report --seeds: only those seeds' cells, in DIR/report-seeds-<list>, bad lists name --seeds", "[report]") {
  CHECK(parse_seed_list("0-4") == std::vector<int64_t>{0, 1, 2, 3, 4});
  CHECK(parse_seed_list("7,0-2") == std::vector<int64_t>{0, 1, 2, 7});
  // The directory and title carry the list in one form whatever order it was typed in.
  CHECK(seed_list_text(parse_seed_list("7,0-2")) == "0-2,7");
  CHECK(seed_list_text({3}) == "3");
  ReportOptions seven;
  seven.seeds = parse_seed_list("7,0-2");
  CHECK(report_dir_name(seven) == "report-seeds-0-2_7");
  CHECK(report_dir_name(ReportOptions{}) == "report");
  for (const char* bad : {"", "4-0", "1,1", "0-2,2", "a", "-1", "1-", ",1", "1,", "0-100000", "1.5"}) {
    INFO(bad);
    CHECK_THROWS_WITH(parse_seed_list(bad), Catch::Contains("--seeds"));
  }
  const std::string dir = (fs::temp_directory_path() / ("atacom_report_seeds_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac"],
                                                          "seeds": [0, 1, 2, 3, 4], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  write_two_level_runs(dir, spec, "sac");
  ReportOptions o;
  o.dir = dir;
  o.seeds = parse_seed_list("0-2");
  const ReportResult r = write_report(o);
  CHECK(r.runs == 6);
  CHECK(r.report_dir == dir + "/report-seeds-0-2");
  CHECK(!fs::exists(dir + "/report"));
  // Seed s shifts the return by s: over seeds 0-2 atacom-sac's mean return is -260 + 1, not -260 + 2.
  bool seen = false;
  for (const auto& row : read_csv(dir + "/report-seeds-0-2/summary.csv"))
    if (row.at("algo") == "atacom-sac" && row.at("metric") == "eval_return_mean") {
      seen = true;
      CHECK(row.at("n") == "3");
      CHECK(close(row.at("mean"), -259.0));
    }
  CHECK(seen);
  CHECK(slurp(dir + "/report-seeds-0-2/summary.md").find("(seeds 0-2 only)") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("report: 'fell far below its best' is measured against max(|best|, what the run gained)", "[report]") {
  const std::string dir = tmp_dir("report_drop");
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table"], "algos": ["atacom-sac"],
                                                          "seeds": [0, 1, 2, 3, 4], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  // seed: first evaluation's return, best, final; seed 3 has no curve; seed 4 never rose above its first.
  const double first[] = {-500, -500, -500, NAN, -100}, best[] = {0.6, -100, -100, 10, -100},
               last[] = {0.34, -130, -150, 8.5, -200};
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const int s = int(c.seed);
    const json sm = {{"env_steps", 3000}, {"eval_return_mean", last[s]}, {"final_distance", 0.04},
                     {"best", {{"eval_return_mean", best[s]}, {"final_distance", 0.04}, {"env_steps", 2000}}}};
    std::ofstream(run / "summary.json") << sm.dump(2);
    if (s != 3)
      std::ofstream(run / "progress.csv") << "env_steps,updates,wall_s,eval_return_mean,final_distance\n"
                                          << "1000,0,0.1,,\n2000,0,0.2," << first[s] << ",0.5\n3000,0,0.3,"
                                          << best[s] << ",0.04\n";
  }
  ReportOptions o;
  o.dir = dir;
  o.resamples = 100;
  const ReportResult res = write_report(o);
  // Scale max(|best|, gain): seed 0 gained 500.6 and gave back 0.26 (10 % of |best| alone = 0.06 flagged it);
  // seed 1 gave back 30 of 400 (under 40); seed 2 50 (over 40); seed 3, without a curve, 1.5 of |best| = 10
  // (over 1); seed 4 gained nothing and fell 100 of |best| = 100 (over 10; the gain alone would not flag it).
  CHECK(res.dropped ==
        std::vector<std::string>{"table-atacom-sac-seed2", "table-atacom-sac-seed3", "table-atacom-sac-seed4"});
  for (const auto& f : read_csv(dir + "/report/final_vs_best.csv"))
    CHECK(f.at("drop") == ((f.at("seed") == "0" || f.at("seed") == "1") ? "0" : "1"));
  fs::remove_all(dir);
}
