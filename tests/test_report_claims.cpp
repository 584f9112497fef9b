// atacom report's check of the paper's claims (claims.csv): each rule's
// verdict on a synthetic sweep whose orderings are known, the numbers equal
// to the report's own tables (a reversed pair: 1 - P, the interval
// mirrored), the shipped claims file parses, and a bad claims file is
// refused naming its key before anything is written.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/data_dir.hpp"
#include "src/core/config_json.hpp"
#include "src/experiments/report.hpp"
#include "src/experiments/report_claims.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "src/experiments/sweep_state.hpp"
#include "tests/csv_rows.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace atacom;

namespace {

// table and nav, sac / atacom-sac / la / la-atacom, 6 seeds. On table
// atacom-sac ends closer than sac in 33 of 36 seed pairs (P 0.917, an
// interval that is not a point) and beats it on every pair on return and
// collisions; on nav the two are equal seed by seed, so P is 0.5 exactly.
// atacom-sac never collides on table; sac collides on seeds 1-5.
void write_claim_runs(const std::string& dir, const SweepSpec& spec) {
  for (const SweepCell& c : sweep_cells(spec)) {
    const fs::path run = fs::path(dir) / c.run_dir();
    fs::create_directories(run);
    const double s = double(c.seed);
    const bool atacom = c.algo == "atacom-sac" || c.algo == "la-atacom";
    double dist = 0, ret = 0, coll = 0;
    if (c.env == "table") {
      dist = atacom ? 0.1 + 0.02 * s : 0.155 + 0.05 * s;
      ret = atacom ? -20 - s : -300 - s;
      coll = atacom ? 0 : s;
    } else {  // nav: the same values for both algorithms of a pair, seed by seed
      dist = 1 + 0.1 * s;
      ret = -100 + 10 * s;
      coll = 3;
    }
    const json sm = {{"env_steps", c.learns ? 3000 : 0}, {"eval_discounted_return_mean", ret}, {"final_distance", dist},
                     {"train_collisions", c.learns ? coll : 0}, {"train_violations", c.learns ? 2 * coll : 0},
                     {"eval_return_mean", ret}};
    std::ofstream(run / "summary.json") << sm.dump(2);
  }
}

json check(const std::string& kind, const std::string& env, const std::string& metric, const std::string& algo) {
  return {{"kind", kind}, {"env", env}, {"metric", metric}, {"algo", algo}};
}

}  // namespace

TEST_CASE("report claims: each rule's verdict, and the numbers of the report's own tables", "[report]") {
  const std::string dir = tmp_dir("claims");
  const SweepSpec spec = parse_sweep_spec(json::parse(R"({"envs": ["table", "nav"],
      "algos": ["sac", "atacom-sac", "la", "la-atacom"], "seeds": [0, 1, 2, 3, 4, 5], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  write_claim_runs(dir, spec);
  json better = check("better", "table", "final_distance", "atacom-sac");
  better["baseline"] = "sac";
  json reversed = better;  // sac better than atacom-sac: the reverse of a report pair
  reversed["algo"] = "sac";
  reversed["baseline"] = "atacom-sac";
  json tie = better;
  tie["env"] = "nav";
  json zero_ok = check("zero", "table", "train_collisions", "atacom-sac");
  json zero_bad = check("zero", "table", "train_collisions", "sac");
  json value_ok = check("paper_value", "table", "final_distance", "atacom-sac");
  value_ok["paper_value"] = 0.2;  // ours 0.1-0.2: at least as good
  json value_bad = value_ok;
  value_bad["paper_value"] = 0.01;  // ours wholly worse
  json absent = check("zero", "hri", "train_collisions", "atacom-sac");
  json no_values = check("paper_value", "table", "spills", "atacom-sac");  // no run has spills
  no_values["paper_value"] = 4;
  const json doc = {{"about", "test"},
                    {"claims",
                     {{{"id", "a"}, {"claim", "x"}, {"paper", "p"}, {"checks", {better, zero_ok, value_ok}}},
                      {{"id", "b"}, {"claim", "y"}, {"paper", "p"}, {"checks", {reversed, zero_bad, value_bad}}},
                      {{"id", "c"}, {"claim", "z"}, {"paper", "p"}, {"checks", {tie}}},
                      {{"id", "d"}, {"claim", "w"}, {"paper", "p"}, {"checks", {better, reversed, tie}}},
                      {{"id", "e"}, {"claim", "v"}, {"paper", "p"}, {"checks", {absent}}},
                      {{"id", "f"}, {"claim", "u"}, {"paper", "p"}, {"checks", {zero_ok, no_values, absent}}}}}};
  const std::string claims_file = dir + "_claims.json";
  std::ofstream(claims_file) << doc.dump(1);
  ReportOptions o;
  o.dir = dir;
  o.resamples = 300;
  o.seed = 5;
  o.claims = claims_file;
  const ReportResult res = write_report(o);
  CHECK(res.claims);

  const auto rows = csv_rows::read(dir + "/report/claims.csv");
  REQUIRE(rows.size() == 3 + 3 + 1 + 3 + 1 + 3);
  const std::vector<std::string> want = {"holds",         "holds",         "holds", "does not hold",
                                         "does not hold", "does not hold", "not separable", "holds",
                                         "does not hold", "not separable", "not in this sweep",
                                         "holds",         "too few runs",  "not in this sweep"};
  for (size_t i = 0; i < rows.size(); ++i) {
    INFO("row " << i);
    CHECK(rows[i].at("verdict") == want[i]);
  }
  CHECK(std::stod(rows[0].at("p_improvement")) == Approx(33.0 / 36));
  CHECK(std::stod(rows[0].at("p_ci_low")) < std::stod(rows[0].at("p_ci_high")));
  CHECK(rows[1].at("nonzero_runs") == "0");
  CHECK(rows[4].at("nonzero_runs") == "5");  // sac collides on seeds 1-5
  CHECK(rows[6].at("p_improvement") == "0.5");

  // The better check is prob_improvement.csv's row; its reverse is 1 - P with the interval mirrored.
  std::map<std::string, std::string> pi;
  for (const auto& r : csv_rows::read(dir + "/report/prob_improvement.csv"))
    if (r.at("env") == "table" && r.at("metric") == "final_distance" && r.at("baseline") == "sac") pi = r;
  REQUIRE(!pi.empty());
  for (const char* k : {"p_improvement", "p_ci_low", "p_ci_high"}) CHECK(rows[0].at(k) == pi.at(k));
  CHECK(std::stod(rows[3].at("p_improvement")) == Approx(1 - std::stod(pi.at("p_improvement"))).margin(1e-12));
  CHECK(std::stod(rows[3].at("p_ci_low")) == Approx(1 - std::stod(pi.at("p_ci_high"))).margin(1e-12));
  CHECK(std::stod(rows[3].at("p_ci_high")) == Approx(1 - std::stod(pi.at("p_ci_low"))).margin(1e-12));
  // The IQM and its interval are summary.csv's.
  for (const auto& r : csv_rows::read(dir + "/report/summary.csv"))
    if (r.at("env") == "table" && r.at("algo") == "atacom-sac" && r.at("metric") == "final_distance") {
      CHECK(rows[2].at("algo_iqm") == r.at("iqm"));
      CHECK(rows[2].at("algo_ci_low") == r.at("iqm_ci_low"));
      CHECK(rows[2].at("algo_ci_high") == r.at("iqm_ci_high"));
    }

  // A claim's verdict: the one its checks share, else the count of each.
  const std::string md = slurp(dir + "/report/summary.md");
  CHECK(md.find("## The paper's claims") < md.find("## table"));
  CHECK(md.find("| **mixed: 1 holds, 1 does not hold, 1 not separable** |") != std::string::npos);
  CHECK(md.find("| **not in this sweep** |") != std::string::npos);
  // A check with too few runs is counted, never passed over; one not in the sweep is left out.
  CHECK(md.find("| **mixed: 1 holds, 1 too few runs** |") != std::string::npos);
  CHECK(slurp(dir + "/report/index.html").find("<h2>The paper's claims</h2>") != std::string::npos);

  // --claims none: no section, and the claims.csv of the report before is gone.
  o.claims = "none";
  REQUIRE(fs::exists(dir + "/report/claims.csv"));
  CHECK_FALSE(write_report(o).claims);
  CHECK_FALSE(fs::exists(dir + "/report/claims.csv"));
  fs::remove_all(dir);
  fs::remove(claims_file);
}

TEST_CASE("report claims: the shipped file parses, a bad one is refused naming the key before any file is written",
          "[report]") {
  const std::vector<Claim> shipped =
      parse_claims(read_json_file(data_file("paper_claims.json")), "data/paper_claims.json");
  CHECK(shipped.size() == 11);
  size_t checks = 0;
  for (const Claim& c : shipped) checks += c.checks.size();
  CHECK(checks == 42);

  const json good = {{"kind", "better"}, {"env", "table"}, {"metric", "final_distance"}, {"algo", "atacom-sac"},
                     {"baseline", "sac"}};
  const auto doc = [](const json& c) {
    return json{{"about", ""}, {"claims", {{{"id", "1"}, {"claim", "c"}, {"paper", "p"}, {"checks", {c}}}}}};
  };
  const auto refused = [&](const json& d) -> std::string {
    try {
      parse_claims(d, "F");
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  CHECK(refused(doc(good)) == "accepted");
  json c = good;
  c["kind"] = "worse";
  CHECK(refused(doc(c)) == "F: claims[0].checks[0].kind is \"worse\", must be one of better, zero, paper_value");
  c = good;
  c["metric"] = "time_to_target_s";  // censored: no claim rule reads it
  CHECK(refused(doc(c)).rfind("F: claims[0].checks[0].metric is \"time_to_target_s\", must be one of "
                              "eval_discounted_return_mean, final_distance", 0) == 0);
  c = good;
  c["metric"] = "shelf_real.success_1";
  CHECK(refused(doc(c)) == "F: claims[0].checks[0].metric: a better check reads a report metric, not shelf_real.success_1");
  c = good;
  c.erase("baseline");
  CHECK(refused(doc(c)) == "missing key 'baseline' in F: claims[0].checks[0]");
  c = good;
  c["paper_value"] = 1;
  CHECK(refused(doc(c)) == "unknown key 'paper_value' in F: claims[0].checks[0]");
  c = {{"kind", "paper_value"}, {"env", "hri"}, {"metric", "spills"}, {"algo", "atacom-sac"}, {"paper_value", "4"}};
  CHECK(refused(doc(c)) == "F: claims[0].checks[0].paper_value has type string, must be a number");
  json twice = doc(good);
  twice["claims"].push_back(twice["claims"][0]);
  CHECK(refused(twice) == "F: claims[1].id '1' is used twice");
  CHECK(refused(json{{"about", ""}, {"claims", json::array()}}) == "F: claims must be a non-empty array");

  // Through the report: refused before DIR/report exists.
  const std::string dir = tmp_dir("claims_bad");
  const SweepSpec spec = parse_sweep_spec(
      json::parse(R"({"envs": ["table"], "algos": ["sac", "atacom-sac"], "seeds": [0, 1, 2], "steps": 3000})"));
  save_or_check_spec(dir, spec);
  write_claim_runs(dir, spec);
  c = good;
  c["kind"] = "worse";
  std::ofstream(dir + "_bad.json") << doc(c).dump();
  ReportOptions o;
  o.dir = dir;
  o.claims = dir + "_bad.json";
  CHECK_THROWS_WITH(write_report(o), Catch::Contains("claims[0].checks[0].kind is \"worse\""));
  CHECK_FALSE(fs::exists(dir + "/report"));
  fs::remove_all(dir);
  fs::remove(dir + "_bad.json");
}
