// The paper's claims in the sweep report (report_claims.hpp).
#include "src/experiments/report_claims.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/value_range.hpp"
#include "src/experiments/report_improvement.hpp"
#include "src/experiments/report_stats.hpp"
#include "src/experiments/report_text.hpp"

namespace atacom {

namespace {

// The ShelfEnvReal numbers a check may read, one value per evaluated policy
// (the report's ShelfEnvReal section), and their key in the section's streams.
struct ShelfRealMetric {
  const char* name;
  const char* stream;
  const std::vector<double>& (*values)(const ShelfRealAlgo&);
};
constexpr ShelfRealMetric kShelfRealMetrics[] = {
    {"shelf_real.success_1", "success1", [](const ShelfRealAlgo& a) -> const std::vector<double>& { return a.success[0]; }},
    {"shelf_real.success_2", "success2", [](const ShelfRealAlgo& a) -> const std::vector<double>& { return a.success[1]; }},
    {"shelf_real.error_1", "error1", [](const ShelfRealAlgo& a) -> const std::vector<double>& { return a.error[0]; }},
    {"shelf_real.error_2", "error2", [](const ShelfRealAlgo& a) -> const std::vector<double>& { return a.error[1]; }},
    {"shelf_real.collisions", "collisions",
     [](const ShelfRealAlgo& a) -> const std::vector<double>& { return a.collisions; }},
};
const ShelfRealMetric* find_shelf_real_metric(const std::string& name) {
  for (const ShelfRealMetric& m : kShelfRealMetrics)
    if (name == m.name) return &m;
  return nullptr;
}
bool is_shelf_real_metric(const std::string& m) { return find_shelf_real_metric(m) != nullptr; }
bool higher_is_better(const std::string& metric) {
  if (const ReportMetric* m = find_report_metric(metric)) return m->higher_better;
  return metric.rfind("shelf_real.success", 0) == 0;
}

std::string text_at(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.contains(key)) throw std::invalid_argument(where + ": missing key '" + key + "'");
  if (!j[key].is_string() || j[key].get<std::string>().empty())
    throw std::invalid_argument(where + "." + key + " must be a non-empty string, is " + value_text(j[key]));
  return j[key].get<std::string>();
}

ClaimCheck parse_check(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw std::invalid_argument(where + " must be a JSON object");
  ClaimCheck c;
  c.kind = text_at(j, "kind", where);
  if (c.kind == "better") require_exact_keys(j, {"kind", "env", "metric", "algo", "baseline"}, where);
  else if (c.kind == "zero") require_exact_keys(j, {"kind", "env", "metric", "algo"}, where);
  else if (c.kind == "paper_value") require_exact_keys(j, {"kind", "env", "metric", "algo", "paper_value"}, where);
  else
    throw std::invalid_argument(where + ".kind is " + value_text(j["kind"]) + ", must be one of better, zero, paper_value");
  c.env = text_at(j, "env", where);
  c.algo = text_at(j, "algo", where);
  c.metric = text_at(j, "metric", where);
  const ReportMetric* m = find_report_metric(c.metric);
  const bool shelf_real = is_shelf_real_metric(c.metric);
  if ((!m || m->censored) && !shelf_real) {
    std::string valid;
    for (const ReportMetric& r : report_metrics())
      if (!r.censored) valid += std::string(valid.empty() ? "" : ", ") + r.key;
    for (const ShelfRealMetric& s : kShelfRealMetrics) valid += std::string(", ") + s.name;
    throw std::invalid_argument(where + ".metric is " + value_text(j["metric"]) + ", must be one of " + valid);
  }
  if (c.kind == "better") {
    if (shelf_real)
      throw std::invalid_argument(where + ".metric: a better check reads a report metric, not " + c.metric);
    c.baseline = text_at(j, "baseline", where);
    if (c.baseline == c.algo) throw std::invalid_argument(where + ".baseline must differ from its algo");
  }
  if (c.kind == "paper_value") c.paper_value = checked_number(j["paper_value"], where + ".paper_value", range::finite());
  return c;
}

// The values of (env, algo) a check reads: finished runs' (report metrics)
// or evaluated policies' (shelf_real.*), in seed order.
std::vector<double> check_values(const ReportData& d, const ShelfRealSection& shelf, const ClaimCheck& c,
                                 const std::string& algo) {
  const ShelfRealMetric* m = find_shelf_real_metric(c.metric);
  if (!m) return metric_values(d, c.env, algo, c.metric);
  if (c.env == "shelf")
    for (const ShelfRealAlgo& a : shelf.algos)
      if (a.algo == algo) return m->values(a);
  return {};
}

// n, IQM and its interval of the values a check reads, with the stream the
// report's own table of those values uses (summary.csv, the ShelfEnvReal table).
struct IqmSummary {
  size_t n = 0;
  double iqm = NAN;
  Interval ci{NAN, NAN};
};
IqmSummary summary_of(const ReportData& d, const ClaimCheck& c, const std::string& algo, const std::vector<double>& v) {
  IqmSummary r;
  r.n = v.size();
  if (v.empty()) return r;
  r.iqm = iqm(v);
  if (v.size() < kMinSeedsForInterval) return r;
  const ShelfRealMetric* m = find_shelf_real_metric(c.metric);
  const std::string stream = m ? shelf_real_stream(algo, m->stream) : c.env + "/" + algo + "/" + c.metric;
  r.ci = bootstrap_iqm_ci(v, d.opts.resamples, d.opts.seed, bootstrap_stream(stream));
  return r;
}

struct CheckResult {
  const Claim* claim = nullptr;
  const ClaimCheck* check = nullptr;
  IqmSummary algo, base;
  Improvement p;
  size_t nonzero = 0;
  std::string verdict, ours;
};

bool in_sweep(const std::vector<std::string>& names, const std::string& x) {
  return std::find(names.begin(), names.end(), x) != names.end();
}

std::string iqm_text(const IqmSummary& s) {
  return short_num(s.iqm) +
         (s.n >= kMinSeedsForInterval ? " [" + short_num(s.ci.low) + ", " + short_num(s.ci.high) + "]" : "");
}

CheckResult evaluate(const ReportData& d, const ShelfRealSection& shelf, const Claim& cl, const ClaimCheck& c) {
  CheckResult r;
  r.claim = &cl;
  r.check = &c;
  if (!in_sweep(d.envs, c.env) || !in_sweep(d.algos, c.algo) || (c.kind == "better" && !in_sweep(d.algos, c.baseline))) {
    r.verdict = "not in this sweep";
    return r;
  }
  const std::vector<double> x = check_values(d, shelf, c, c.algo);
  r.algo = summary_of(d, c, c.algo, x);
  if (c.kind == "zero") {
    for (double v : x) r.nonzero += v != 0;
    if (x.empty()) r.verdict = "too few runs";
    else r.verdict = r.nonzero == 0 ? "holds" : "does not hold";
    r.ours = r.nonzero == 0 ? "0 in " + std::to_string(x.size()) + " of " + std::to_string(x.size()) + " runs"
                            : "not 0 in " + std::to_string(r.nonzero) + " of " + std::to_string(x.size()) +
                                  " runs (IQM " + iqm_text(r.algo) + ")";
    return r;
  }
  if (c.kind == "paper_value") {
    r.ours = iqm_text(r.algo) + " (n = " + std::to_string(x.size()) + ") vs the paper's " +
             short_num(c.paper_value);
    if (x.size() < kMinSeedsForInterval) {
      r.verdict = "too few runs";
      return r;
    }
    const bool worse = higher_is_better(c.metric) ? r.algo.ci.high < c.paper_value : r.algo.ci.low > c.paper_value;
    r.verdict = worse ? "does not hold" : "holds";
    return r;
  }
  r.base = summary_of(d, c, c.baseline, check_values(d, shelf, c, c.baseline));
  r.p = improvement(d, c.env, *find_report_metric(c.metric), c.algo, c.baseline);
  r.ours = "IQM " + iqm_text(r.algo) + " vs " + iqm_text(r.base);
  if (std::isnan(r.p.p)) {
    r.verdict = "too few runs";
    return r;
  }
  r.ours = "P " + short_num(r.p.p) + " [" + short_num(r.p.ci.low) + ", " + short_num(r.p.ci.high) + "]; " + r.ours;
  r.verdict = r.p.ci.low > 0.5 ? "holds" : r.p.ci.high < 0.5 ? "does not hold" : "not separable";
  return r;
}

// A claim's verdict from its checks': the one they all share, or the count
// of each ("mixed: 2 hold, 1 too few runs"); checks not in this sweep are
// left out.
std::string claim_verdict(const std::vector<CheckResult>& rs, const Claim& cl) {
  size_t held = 0, failed = 0, open = 0, few = 0;
  for (const CheckResult& r : rs) {
    if (r.claim != &cl) continue;
    held += r.verdict == "holds";
    failed += r.verdict == "does not hold";
    open += r.verdict == "not separable";
    few += r.verdict == "too few runs";
  }
  const size_t counted = held + failed + open + few;
  if (counted == 0) return "not in this sweep";
  if (held == counted) return "holds";
  if (failed == counted) return "does not hold";
  if (open == counted) return "not separable";
  if (few == counted) return "too few runs";
  std::string v;
  const auto part = [&](size_t k, const char* one, const char* many) {
    if (k > 0) v += (v.empty() ? "mixed: " : ", ") + std::to_string(k) + (k == 1 ? one : many);
  };
  part(held, " holds", " hold");
  part(failed, " does not hold", " do not hold");
  part(open, " not separable", " not separable");
  part(few, " too few runs", " too few runs");
  return v;
}

std::string check_text(const ClaimCheck& c) {
  const std::string metric = c.metric + " (" + (higher_is_better(c.metric) ? "higher" : "lower") + " is better)";
  if (c.kind == "better") return c.env + ": " + c.algo + " better than " + c.baseline + " on " + metric;
  if (c.kind == "zero") return c.env + ": " + c.algo + "'s " + c.metric + " is 0 in every run";
  return c.env + ": " + c.algo + "'s " + metric + " as good as the paper's " + short_num(c.paper_value) + " or better";
}

const char* verdict_class(const std::string& v) {
  if (v == "holds") return "good";
  if (v == "does not hold") return "bad";
  if (v == "not separable" || v.rfind("mixed", 0) == 0) return "";
  return "na";
}

std::string csv_cell(std::string s) {
  for (char& c : s)
    if (c == ',' || c == '\n' || c == '"') c = ';';
  return s;
}

}  // namespace

std::vector<Claim> parse_claims(const nlohmann::json& doc, const std::string& what) {
  if (!doc.is_object()) throw std::invalid_argument(what + " must be a JSON object");
  require_exact_keys(doc, {"about", "claims"}, what);
  if (!doc["claims"].is_array() || doc["claims"].empty())
    throw std::invalid_argument(what + ": claims must be a non-empty array");
  std::vector<Claim> out;
  for (size_t i = 0; i < doc["claims"].size(); ++i) {
    const nlohmann::json& j = doc["claims"][i];
    const std::string where = what + ": claims[" + std::to_string(i) + "]";
    require_exact_keys(j, {"id", "claim", "paper", "checks"}, where);
    Claim c{text_at(j, "id", where), text_at(j, "claim", where), text_at(j, "paper", where), {}};
    for (const Claim& o : out)
      if (o.id == c.id) throw std::invalid_argument(where + ".id '" + printable_text(c.id) + "' is used twice");
    if (!j["checks"].is_array() || j["checks"].empty())
      throw std::invalid_argument(where + ".checks must be a non-empty array");
    for (size_t k = 0; k < j["checks"].size(); ++k)
      c.checks.push_back(parse_check(j["checks"][k], where + ".checks[" + std::to_string(k) + "]"));
    out.push_back(std::move(c));
  }
  return out;
}

bool write_claims(const ReportData& d, const ShelfRealSection& shelf, const std::vector<Claim>& claims,
                  const std::string& csv_path, std::ostream& md, std::ostream& html) {
  std::vector<CheckResult> rs;
  for (const Claim& cl : claims)
    for (const ClaimCheck& c : cl.checks) rs.push_back(evaluate(d, shelf, cl, c));
  if (std::all_of(rs.begin(), rs.end(), [](const CheckResult& r) { return r.verdict == "not in this sweep"; }))
    return false;

  std::string csv =
      "claim,kind,env,metric,algo,baseline,paper_value,n_algo,n_baseline,algo_iqm,algo_ci_low,algo_ci_high,"
      "baseline_iqm,baseline_ci_low,baseline_ci_high,p_improvement,p_ci_low,p_ci_high,nonzero_runs,verdict\n";
  for (const CheckResult& r : rs) {
    const ClaimCheck& c = *r.check;
    csv += csv_cell(r.claim->id) + "," + c.kind + "," + csv_cell(c.env) + "," + c.metric + "," + csv_cell(c.algo) +
           "," + csv_cell(c.baseline) + "," + (c.kind == "paper_value" ? num(c.paper_value) : "") + "," +
           std::to_string(r.algo.n) + "," + (c.kind == "better" ? std::to_string(r.base.n) : "") + "," +
           num_or_empty(r.algo.iqm) + "," + num_or_empty(r.algo.ci.low) + "," + num_or_empty(r.algo.ci.high) + "," +
           num_or_empty(r.base.iqm) + "," + num_or_empty(r.base.ci.low) + "," + num_or_empty(r.base.ci.high) + "," +
           num_or_empty(r.p.p) + "," + num_or_empty(r.p.ci.low) + "," + num_or_empty(r.p.ci.high) + "," +
           (c.kind == "zero" ? std::to_string(r.nonzero) : "") + "," + r.verdict + "\n";
  }
  write_file_atomic(csv_path, csv);

  const std::string note =
      "Each claim of the paper is a few checks of this sweep's numbers (claims.csv; the rules: "
      "data/paper_claims.json). better: P(improvement) with its 95% interval, holds above 0.5, does not hold "
      "below, not separable when the interval holds 0.5. zero: every run's value is 0. paper_value: ours "
      "(IQM [95% CI]) against the paper's number, holds unless the interval is wholly worse. The paper ran 25 "
      "seeds x 2M steps: check this sweep's steps and seeds before reading a verdict as the paper's.";
  md << "## The paper's claims\n\n" << note << "\n\n| # | claim | paper | check | ours | verdict |\n|---|---|---|---|---|---|\n";
  html << "<h2>The paper's claims</h2><p class=\"note\">" << html_escape(note) << "</p>"
       << "<table><tr><th>#</th><th>claim</th><th>paper</th><th>check</th><th>ours</th><th>verdict</th></tr>\n";
  for (const Claim& cl : claims) {
    const std::string v = claim_verdict(rs, cl);
    md << "| " << markdown_text(cl.id) << " | " << markdown_text(cl.claim) << " | " << markdown_text(cl.paper)
       << " | | | **" << v << "** |\n";
    html << "<tr><td class=\"l\">" << html_escape(cl.id) << "</td><td class=\"l\">" << html_escape(cl.claim)
         << "</td><td class=\"l\">" << html_escape(cl.paper) << "</td><td></td><td></td><td class=\""
         << verdict_class(v) << "\"><b>" << html_escape(v) << "</b></td></tr>\n";
    for (const CheckResult& r : rs) {
      if (r.claim != &cl) continue;
      md << "| | | | " << markdown_text(check_text(*r.check)) << " | " << markdown_text(r.ours) << " | " << r.verdict
         << " |\n";
      html << "<tr><td></td><td></td><td></td><td class=\"l\">" << html_escape(check_text(*r.check))
           << "</td><td class=\"l\">" << html_escape(r.ours) << "</td><td class=\"" << verdict_class(r.verdict)
           << "\">" << html_escape(r.verdict) << "</td></tr>\n";
    }
  }
  md << "\n";
  html << "</table>\n";
  return true;
}

}  // namespace atacom
