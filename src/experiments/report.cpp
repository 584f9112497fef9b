// atacom report: tables (CSV, Markdown), figures (SVG) and one HTML page.
#include "src/experiments/report.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "src/core/config_json.hpp"
#include "src/core/data_dir.hpp"
#include "src/core/fs_util.hpp"
#include "src/experiments/report_claims.hpp"
#include "src/experiments/report_data.hpp"
#include "src/experiments/report_improvement.hpp"
#include "src/experiments/report_shelf_real.hpp"
#include "src/experiments/report_text.hpp"
#include "src/experiments/report_stats.hpp"

namespace fs = std::filesystem;

namespace atacom {

namespace {

constexpr size_t kMinSeeds = kMinSeedsForInterval;

struct Row {
  std::string env, algo, metric;
  size_t n = 0;
  size_t reached = 0;  // finite values (censored metrics: the runs that met the target)
  double mean = NAN, std = NAN, median = NAN, q1 = NAN, q3 = NAN, iqm = NAN;
  Interval ci{NAN, NAN};
};

struct Pi {
  std::string env, metric, algo, baseline;
  size_t nx = 0, ny = 0;
  double p = NAN;
  Interval ci{NAN, NAN};  // 95 % bootstrap interval of p
};

struct Drop {
  const ReportRun* run;
  double final_ret, best_ret, best_steps, final_dist, best_dist;
  bool dropped;
};

// The rows of the plain metrics (censored = false) or of the censored ones,
// whose runs that never met the target are in v as +inf (no mean or std).
std::vector<Row> table_rows(const ReportData& d, bool censored) {
  std::vector<Row> rows;
  for (const auto& env : d.envs)
    for (const auto& algo : d.algos)
      for (const ReportMetric& m : report_metrics()) {
        if (m.censored != censored) continue;
        const std::vector<double> v = metric_values(d, env, algo, m.key);
        if (v.empty()) continue;
        Row r{env, algo, m.key};
        r.n = v.size();
        for (double x : v) r.reached += std::isfinite(x);
        if (!censored) {
          r.mean = mean_of(v);
          r.std = sample_std(v);
        }
        r.median = quantile(v, 0.5);
        r.q1 = quantile(v, 0.25);
        r.q3 = quantile(v, 0.75);
        r.iqm = iqm(v);
        if (r.n >= kMinSeeds)
          r.ci = bootstrap_iqm_ci(v, d.opts.resamples, d.opts.seed, bootstrap_stream(env + "/" + algo + "/" + m.key));
        rows.push_back(r);
      }
  return rows;
}

std::vector<Pi> improvements(const ReportData& d) {
  std::vector<Pi> out;
  for (const auto& env : d.envs)
    for (const auto& [algo, base] : improvement_pairs(d))
      for (const ReportMetric& m : report_metrics()) {
        if (!m.boxplot && !m.censored) continue;
        const Improvement i = improvement(d, env, m, algo, base);
        if (i.n_algo == 0 || i.n_baseline == 0) continue;
        out.push_back({env, m.key, algo, base, i.n_algo, i.n_baseline, i.p, i.ci});
      }
  return out;
}

std::vector<Drop> drops(const ReportData& d) {
  std::vector<Drop> out;
  for (const ReportRun& r : d.runs) {
    if (!r.finished) continue;
    Drop x{&r, NAN, NAN, NAN, NAN, NAN, false};
    x.final_ret = metric_value(r.summary, "eval_return_mean").value_or(NAN);
    x.best_ret = metric_value(r.summary, "best.eval_return_mean").value_or(NAN);
    x.best_steps = metric_value(r.summary, "best.env_steps").value_or(NAN);
    x.final_dist = metric_value(r.summary, "final_distance").value_or(NAN);
    x.best_dist = metric_value(r.summary, "best.final_distance").value_or(NAN);
    // The return's scale: the larger of |best| and what the run gained over
    // its first evaluation. |best| alone misfires near a best of 0 (0.61 ->
    // 0.34 at 0.04 m after a climb from -500); the gain alone never flags a
    // run that collapsed without first improving.
    const auto first = std::find_if(r.eval_return.begin(), r.eval_return.end(), [](double v) { return std::isfinite(v); });
    const double gain = first == r.eval_return.end() ? 0.0 : x.best_ret - *first;
    const double scale = std::max(std::abs(x.best_ret), gain);
    x.dropped = (x.final_ret < x.best_ret - d.opts.drop_return_frac * scale) ||
                (x.final_dist > x.best_dist + d.opts.drop_distance);
    out.push_back(x);
  }
  return out;
}

const ReportMetric& metric_info(const std::string& key) {
  for (const ReportMetric& m : report_metrics())
    if (key == m.key) return m;
  throw std::logic_error("unknown report metric " + key);
}

std::string target_methods_text() {
  return "Time to target: the first evaluation whose mean final distance is within the env's target distance (and, "
         "where the env says so, every listed evaluation column 0: HRI-Sim no spill), as summary.json records it. A "
         "run that never met the target is censored, not dropped: it counts as +inf (later than every run that met "
         "it; its budget is a lower bound). Quantiles and the IQM are computed over all finished runs with those "
         "values, so the IQM is finite while at most a quarter of the runs (floor(n/4)) never reached the target; "
         "the bootstrap interval is formed the same way, and a bound reads 'not reached' when more than 2.5% of the "
         "resamples hold too many censored runs for a finite IQM.";
}

std::string methods_text(const ReportData& d) {
  const std::string main = main_algorithm(d);
  return "Statistics over seeds per (env, algo): mean, sample std (n - 1), median and quartiles (linear "
         "interpolation, numpy's default), IQM = 25%-trimmed mean, its 95% percentile-bootstrap interval (" +
         std::to_string(d.opts.resamples) + " resamples of the seeds with replacement, seed " +
         std::to_string(d.opts.seed) + "; one task per cell, so stratified = within the cell; curves: " +
         std::to_string(d.opts.curve_resamples) +
         " resamples per evaluation). " +
         (main.empty()
              ? std::string("P(improvement): not formed (neither atacom-sac nor atacom-ppo ran). ")
              : "P(improvement) of " + main + " over a baseline: Mann-Whitney form, over all seed pairs 1 if " + main +
                    " is better, 1/2 if equal, with a 95% percentile-bootstrap interval (both algorithms' "
                    "seeds resampled); the same for every other source through ATACOM over that source without a "
                    "layer, when both ran (la-atacom over la). ") +
         "Final-policy metrics are the last evaluation; "
         "training metrics count over all training steps. Cost: a step costs 1 when a constraint row exceeds its "
         "stated tolerance or a collision / joint-limit event happens (Safety-Gymnasium's convention); eval_cost_mean "
         "is the final policy's cost per episode, train_cost the cost summed over training; a cost axis is "
         "log10(1 + cost) when its largest value is 100 or more; the training cost until the quality target is "
         "the time-to-target figure's train_cost_to_target (collisions + violating steps, so a step with both "
         "counts twice there and once in train_cost). Colours are fixed per algorithm in every figure. A run is "
         "flagged when its final evaluation return is more than " + short_num(100 * d.opts.drop_return_frac) +
         "% of max(|best|, best - first evaluation's) below its best evaluation's, or its final distance more than " +
         short_num(d.opts.drop_distance) + " m above the best's.";
}

// What a sweep with fewer than kMinSeeds seeds per cell can and cannot show ("" with enough seeds).
std::string seeds_note(size_t most) {
  if (most >= kMinSeeds) return "";
  const std::string n = std::to_string(most);
  return "At most " + n + " seed" + (most == 1 ? "" : "s") + " per cell: the tables show " +
         (most == 1 ? "one run's values for each algorithm" : "these runs' values") +
         ", which say what happened in " + (most == 1 ? "that run" : "these runs") +
         " (for example whether training hit the table, and the final distance reached) but not how often it "
         "would happen again or whether a difference between algorithms is larger than the spread between seeds. "
         "Intervals and P(improvement) need at least " + std::to_string(kMinSeeds) +
         " seeds per cell (cells with fewer say so, in grey); run more seeds, e.g. configs/sweeps/quick.json "
         "(3 seeds) or paper.json (25).";
}

// "0.96 [0.88, 1]" over the evaluated policies; no interval below kMinSeeds.
std::string iqm_text(const std::vector<double>& v, const ReportData& d, const std::string& stream, bool attractor) {
  if (v.empty()) return "-";
  if (attractor) return short_num(v[0]);
  std::string t = short_num(iqm(v));
  if (v.size() < kMinSeeds) return t + " (" + no_stat(v.size(), "interval") + ")";
  const Interval ci = bootstrap_iqm_ci(v, d.opts.resamples, d.opts.seed, bootstrap_stream(stream));
  return t + " [" + short_num(ci.low) + ", " + short_num(ci.high) + "]";
}

// The ShelfEnvReal section: shelf_real.csv (a row per evaluated run and
// target, skipped runs with their reason) and a table per algorithm.
void write_shelf_real(const ReportData& d, const ShelfRealSection& s, const std::string& csv_path,
                      std::ostringstream& md, std::ostringstream& html) {
  if (s.runs.empty()) return;
  std::string csv = "algo,seed,safety,target,success_rate,final_error_mean,final_error_std,collisions,time_mean,"
                    "time_std,violation_steps,skipped\n";
  for (const ShelfRealRun& r : s.runs) {
    const std::string head = r.run->cell.algo + "," + std::to_string(r.run->cell.seed) + "," + r.safety + ",";
    if (!r.skipped.empty()) {
      std::string why = r.skipped;
      for (char& c : why)
        if (c == ',' || c == '\n' || c == '"') c = ';';
      csv += head + ",,,,,,,," + why + "\n";
      continue;
    }
    for (size_t t = 0; t < r.result.targets.size(); ++t) {
      const ShelfRealTarget& x = r.result.targets[t];
      csv += head + std::to_string(t + 1) + "," + num(x.success_rate) + "," + num(x.final_error_mean) + "," +
             num(x.final_error_std) + "," + std::to_string(x.collisions) + "," +
             (x.success_rate > 0 ? num(x.time_mean) + "," + num(x.time_std) : std::string(",")) + "," + std::to_string(r.result.max_constraint_violations) + ",\n";
    }
  }
  write_file_atomic(csv_path, csv);
  const std::string note =
      "Every finished shelf policy through the ShelfEnvReal protocol (atacom shelf-real: " +
      std::to_string(s.protocol.trials) + " trials, two sequential targets, success = within " +
      short_num(s.protocol.success_radius) + " m for " + short_num(s.protocol.hold_time) + " s, at most " +
      short_num(s.protocol.max_time_per_target) +
      " s per target), the final policy, the run's env settings and layer, the same trials (protocol seed " +
      std::to_string(s.protocol.seed) +
      ") for every policy. Success and final error are IQM [95 % CI] over policies; an attractor is deterministic, "
      "one evaluation. Collisions and violation steps are summed over policies. The paper (one ATACOM-SAC policy, "
      "real TIAGo): success 90 % / 90 %, final error 0.038 / 0.047 m, 0 collisions.";
  md << "## ShelfEnvReal\n\n" << note << "\n\n| algo | layer | policies | success 1 | success 2 | final error 1 [m] | "
     << "final error 2 [m] | collisions | violation steps |\n|---|---|---|---|---|---|---|---|---|\n";
  html << "<h2>ShelfEnvReal</h2><p class=\"note\">" << html_escape(note) << "</p><table><tr><th>algo</th>"
       << "<th>layer</th><th>policies</th><th>success 1</th><th>success 2</th><th>final error 1 [m]</th>"
       << "<th>final error 2 [m]</th><th>collisions</th><th>violation steps</th></tr>\n";
  for (const ShelfRealAlgo& a : s.algos) {
    const std::string n = a.attractor ? "1 (deterministic)" : std::to_string(a.n);
    const std::string c[4] = {iqm_text(a.success[0], d, shelf_real_stream(a.algo, "success1"), a.attractor),
                              iqm_text(a.success[1], d, shelf_real_stream(a.algo, "success2"), a.attractor),
                              iqm_text(a.error[0], d, shelf_real_stream(a.algo, "error1"), a.attractor),
                              iqm_text(a.error[1], d, shelf_real_stream(a.algo, "error2"), a.attractor)};
    md << "| " << a.algo << " | " << a.safety << " | " << n;
    html << "<tr><td class=\"l\">" << a.algo << "</td><td class=\"l\">" << a.safety << "</td><td>" << n << "</td>";
    for (const std::string& x : c) {
      md << " | " << x;
      html << "<td>" << x << "</td>";
    }
    md << " | " << a.total_collisions() << " | " << a.violation_steps << " |\n";
    html << "<td" << (a.total_collisions() > 0 ? " class=\"bad\"" : "") << ">" << a.total_collisions() << "</td><td>"
         << a.violation_steps << "</td></tr>\n";
  }
  html << "</table>\n";
  md << "\n";
  // Skipped runs, one line per algorithm and reason: "safelayer-sac (seeds 0, 1, 2): ...".
  struct Skipped {
    std::string algo, why, seeds;
  };
  std::vector<Skipped> skipped;
  for (const ShelfRealRun& r : s.runs) {
    if (r.skipped.empty()) continue;
    const std::string seed = std::to_string(r.run->cell.seed);
    auto it = std::find_if(skipped.begin(), skipped.end(),
                           [&](const Skipped& x) { return x.algo == r.run->cell.algo && x.why == r.skipped; });
    if (it == skipped.end()) skipped.push_back({r.run->cell.algo, r.skipped, seed});
    else it->seeds += ", " + seed;
  }
  if (skipped.empty()) return;
  md << "Not evaluated:\n\n";
  html << "<p class=\"note\">Not evaluated:</p><ul>";
  for (const Skipped& x : skipped) {
    const std::string who = x.algo + " (seeds " + x.seeds + ")";
    md << "- " << who << ": " << markdown_text(x.why) << "\n";
    html << "<li>" << html_escape(who + ": " + x.why) << "</li>";
  }
  md << "\n";
  html << "</ul>\n";
}

}  // namespace

std::vector<int64_t> parse_seed_list(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument("--seeds '" + printable_text(text, 200) + "': " + why +
                                 " (a list like 0-4 or 0,2,5 of seeds >= 0, at most 100000)");
  };
  if (text.empty() || text.size() > 1000) throw bad("empty or too long");
  std::vector<int64_t> out;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, ',');) {
    const size_t dash = part.find('-');
    const auto number = [&](const std::string& t) {
      if (t.empty() || t.size() > 18 || t.find_first_not_of("0123456789") != std::string::npos)
        throw bad("'" + printable_text(t, 40) + "' is not a seed");
      return int64_t(std::stoll(t));
    };
    const int64_t lo = number(part.substr(0, dash));
    const int64_t hi = dash == std::string::npos ? lo : number(part.substr(dash + 1));
    if (hi < lo) throw bad("a range runs downwards");
    if (hi - lo >= 100000 || out.size() + size_t(hi - lo + 1) > 100000) throw bad("too many seeds");
    for (int64_t v = lo; v <= hi; ++v) out.push_back(v);
  }
  if (text.back() == ',') throw bad("a trailing comma");
  std::sort(out.begin(), out.end());
  if (std::adjacent_find(out.begin(), out.end()) != out.end()) throw bad("a seed repeats");
  return out;
}

std::string seed_list_text(const std::vector<int64_t>& seeds) {
  std::string out;
  for (size_t i = 0; i < seeds.size();) {
    size_t j = i;
    while (j + 1 < seeds.size() && seeds[j + 1] == seeds[j] + 1) ++j;
    if (!out.empty()) out += ',';
    out += std::to_string(seeds[i]);
    if (j > i) out.append(1, '-').append(std::to_string(seeds[j]));
    i = j + 1;
  }
  return out;
}

std::string report_dir_name(const ReportOptions& opts) {
  if (opts.seeds.empty()) return "report";
  std::string list = seed_list_text(opts.seeds);
  std::replace(list.begin(), list.end(), ',', '_');
  return "report-seeds-" + list;
}

ReportResult write_report(const ReportOptions& opts) {
  const ReportData d = load_report_data(opts);
  // Read before anything is written, so a bad claims file leaves no half report.
  std::vector<Claim> claims;
  if (opts.claims != "none") {
    const std::string path = opts.claims.empty() ? data_file("paper_claims.json") : opts.claims;
    claims = parse_claims(read_json_file(path, "claims file '" + printable_text(path) + "'"), "claims file '" + printable_text(path) + "'");
  }
  ReportResult res;
  const std::string name = report_dir_name(opts);
  res.report_dir = (fs::path(opts.dir) / name).string();
  res.index_html = (fs::path(res.report_dir) / "index.html").string();
  res.runs = int(d.runs.size());
  for (const ReportRun& r : d.runs) {
    res.finished += r.finished;
    if (!r.finished) res.missing.push_back(r.cell.name());
  }
  if (res.finished == 0)
    throw std::invalid_argument("sweep directory '" + opts.dir + "' holds no finished run yet (see `atacom sweep status " +
                                opts.dir + "`)");
  // DIR/report is written into: a symlink (or a file) in its place is refused, never written through.
  require_no_links(opts.dir, name, "sweep directory");
  if (fs::symlink_status(res.report_dir).type() != fs::file_type::not_found && !fs::is_directory(fs::symlink_status(res.report_dir)))
    throw std::invalid_argument("sweep directory '" + opts.dir + "': '" + name + "' is not a directory");
  fs::create_directories(res.report_dir);
  const auto out = [&](const std::string& name) { return (fs::path(res.report_dir) / name).string(); };

  const std::vector<Row> rows = table_rows(d, false), trows = table_rows(d, true);
  const std::vector<Pi> pis = improvements(d);
  const std::vector<Drop> dr = drops(d);
  for (const Drop& x : dr)
    if (x.dropped) res.dropped.push_back(x.run->cell.name());

  // ---- CSV
  std::string csv = "env,algo,metric,n,mean,std,median,q1,q3,iqm,iqm_ci_low,iqm_ci_high\n";
  for (const Row& r : rows)
    csv += r.env + "," + r.algo + "," + r.metric + "," + std::to_string(r.n) + "," + num(r.mean) + "," + num(r.std) +
           "," + num(r.median) + "," + num(r.q1) + "," + num(r.q3) + "," + num(r.iqm) + "," +
           (r.n >= kMinSeeds ? num(r.ci.low) + "," + num(r.ci.high) : std::string(",")) + "\n";
  write_file_atomic(out("summary.csv"), csv);
  std::string tcsv = "env,algo,metric,n,reached,median,q1,q3,iqm,iqm_ci_low,iqm_ci_high\n";
  for (const Row& r : trows)
    tcsv += r.env + "," + r.algo + "," + r.metric + "," + std::to_string(r.n) + "," + std::to_string(r.reached) + "," +
            num(r.median) + "," + num(r.q1) + "," + num(r.q3) + "," + num(r.iqm) + "," + num(r.ci.low) + "," +
            num(r.ci.high) + "\n";
  write_file_atomic(out("time_to_target.csv"), tcsv);
  std::string pcsv = "env,metric,algo,baseline,n_algo,n_baseline,p_improvement,p_ci_low,p_ci_high\n";
  for (const Pi& p : pis)
    pcsv += p.env + "," + p.metric + "," + p.algo + "," + p.baseline + "," + std::to_string(p.nx) + "," +
            std::to_string(p.ny) + "," + num_or_empty(p.p) + "," + num_or_empty(p.ci.low) + "," +
            num_or_empty(p.ci.high) + "\n";
  write_file_atomic(out("prob_improvement.csv"), pcsv);
  std::string fcsv = "env,algo,seed,final_return,best_return,best_env_steps,final_distance,best_final_distance,drop\n";
  for (const Drop& x : dr)
    fcsv += x.run->cell.env + "," + x.run->cell.algo + "," + std::to_string(x.run->cell.seed) + "," + num(x.final_ret) +
            "," + num(x.best_ret) + "," + num(x.best_steps) + "," + num(x.final_dist) + "," + num(x.best_dist) + "," +
            (x.dropped ? "1" : "0") + "\n";
  write_file_atomic(out("final_vs_best.csv"), fcsv);
  std::string mcsv = "env,algo,seed,state,log\n";
  for (const ReportRun& r : d.runs)
    if (!r.finished)
      mcsv += r.cell.env + "," + r.cell.algo + "," + std::to_string(r.cell.seed) + "," + r.state + "," + r.log + "\n";
  write_file_atomic(out("missing.csv"), mcsv);

  // ---- figures
  std::vector<std::pair<std::string, std::string>> figs;  // file, svg
  std::vector<std::string> target_envs;  // envs with a censored row: a target figure and table
  for (const auto& env : d.envs) {
    figs.emplace_back("box_" + env + ".svg", boxplot_svg(d, env));
    figs.emplace_back("curves_" + env + ".svg", curves_svg(d, env));
    figs.emplace_back("cost_return_" + env + ".svg", cost_return_svg(d, env));
    figs.emplace_back("train_cost_" + env + ".svg", train_cost_svg(d, env));
    bool any = false;
    for (const Row& r : trows) any = any || r.env == env;
    if (!any) continue;
    target_envs.push_back(env);
    figs.emplace_back("target_" + env + ".svg", target_boxplot_svg(d, env));
  }
  for (const auto& [f, svg] : figs) write_file_atomic(out(f), svg);

  // ---- Markdown and HTML, side by side
  std::ostringstream md, html;
  const std::string subset = opts.seeds.empty() ? "" : " (seeds " + seed_list_text(opts.seeds) + " only)";
  md << "# Sweep report: " << markdown_text(opts.dir) << "\n\n" << res.finished << " of " << res.runs << " runs finished"
     << subset << ".\n\n"
     << methods_text(d) << "\n\n";
  size_t most_seeds = 0;
  for (const Row& r : rows) most_seeds = std::max(most_seeds, r.n);
  const std::string few = seeds_note(most_seeds);
  if (!few.empty()) md << "**" << few << "**\n\n";
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>atacom sweep report</title>\n<style>"
          "body{font-family:sans-serif;margin:20px;color:#222}table{border-collapse:collapse;margin:8px 0 20px}"
          "td,th{border:1px solid #ccc;padding:3px 7px;font-size:13px;text-align:right}th{background:#f3f3f3}"
          "td.l{text-align:left}.bad{background:#fdd}.good{background:#dfd}td.na{background:#eee;color:#777}"
          "svg{max-width:100%;height:auto}"
          "p.note{max-width:60em;font-size:13px}</style></head><body>\n"
       << "<h1>Sweep report</h1><p>" << html_escape(opts.dir) << ": " << res.finished << " of " << res.runs
       << " runs finished" << html_escape(subset) << ".</p>" << (few.empty() ? "" : "<p class=\"note\"><b>" + html_escape(few) + "</b></p>")
       << "<p class=\"note\">" << html_escape(methods_text(d)) << "</p>\n";
  const ShelfRealSection shelf = shelf_real_section(d);
  res.claims = write_claims(d, shelf, claims, out("claims.csv"), md, html);
  // A file this report has no section for goes, so DIR/report never mixes two reports' files.
  if (!res.claims) fs::remove(out("claims.csv"));
  if (shelf.runs.empty()) fs::remove(out("shelf_real.csv"));
  for (const auto& env : d.envs) {
    md << "## " << env << "\n\n![boxplots](box_" << env << ".svg)\n\n![curves](curves_" << env << ".svg)\n\n"
       << "![cost and return](cost_return_" << env << ".svg)\n\n![training cost](train_cost_" << env << ".svg)\n\n";
    html << "<h2>" << html_escape(env) << "</h2>\n";
    for (const auto& [f, svg] : figs)
      for (const char* kind : {"box_", "curves_", "cost_return_", "train_cost_"})
        if (f == kind + env + ".svg") html << "<div>" << svg << "</div>\n";
    md << "| algo | metric | n | IQM [95% CI] | mean +- std | median [q1, q3] |\n|---|---|---|---|---|---|\n";
    html << "<table><tr><th>algo</th><th>metric</th><th>n</th><th>IQM [95% CI]</th><th>mean &plusmn; std</th>"
            "<th>median [q1, q3]</th></tr>\n";
    for (const Row& r : rows) {
      if (r.env != env) continue;
      const bool ci = r.n >= kMinSeeds;
      const std::string iq = short_num(r.iqm) + (ci ? " [" + short_num(r.ci.low) + ", " + short_num(r.ci.high) + "]"
                                                    : " (" + no_stat(r.n, "interval") + ")");
      const std::string ms = short_num(r.mean) + " +- " + short_num(r.std);
      const std::string mq = short_num(r.median) + " [" + short_num(r.q1) + ", " + short_num(r.q3) + "]";
      md << "| " << r.algo << " | " << r.metric << " | " << r.n << " | " << iq << " | " << ms << " | " << mq << " |\n";
      html << "<tr><td class=\"l\">" << r.algo << "</td><td class=\"l\">" << r.metric << "</td><td>" << r.n
           << "</td><td" << (ci ? "" : " class=\"na\"") << ">" << iq << "</td><td>" << short_num(r.mean) << " &plusmn; " << short_num(r.std) << "</td><td>"
           << mq << "</td></tr>\n";
    }
    md << "\n";
    html << "</table>\n";
    if (std::find(target_envs.begin(), target_envs.end(), env) != target_envs.end()) {
      md << "### Time to target\n\n![time to target](target_" << env << ".svg)\n\n"
         << "| algo | metric | reached | IQM [95% CI] | median [q1, q3] |\n|---|---|---|---|---|\n";
      html << "<h3>Time to target</h3><div>";
      for (const auto& [f, svg] : figs)
        if (f == "target_" + env + ".svg") html << svg;
      html << "</div><table><tr><th>algo</th><th>metric</th><th>reached</th><th>IQM [95% CI]</th>"
              "<th>median [q1, q3]</th></tr>\n";
      for (const Row& r : trows) {
        if (r.env != env) continue;
        const std::string reached = std::to_string(r.reached) + "/" + std::to_string(r.n);
        const std::string iq = target_num(r.iqm) + " [" + target_num(r.ci.low) + ", " + target_num(r.ci.high) + "]";
        const std::string mq = target_num(r.median) + " [" + target_num(r.q1) + ", " + target_num(r.q3) + "]";
        md << "| " << r.algo << " | " << r.metric << " | " << reached << " | " << iq << " | " << mq << " |\n";
        html << "<tr><td class=\"l\">" << r.algo << "</td><td class=\"l\">" << r.metric << "</td><td"
             << (r.reached < r.n ? " class=\"bad\"" : "") << ">" << reached << "</td><td>" << iq << "</td><td>" << mq
             << "</td></tr>\n";
      }
      md << "\n" << target_methods_text() << "\n\n";
      html << "</table><p class=\"note\">" << html_escape(target_methods_text()) << "</p>\n";
    }
    // One table per algorithm that improves on baselines here: the main one, then each source through ATACOM.
    std::vector<std::string> improvers;
    for (const Pi& p : pis)
      if (p.env == env && std::find(improvers.begin(), improvers.end(), p.algo) == improvers.end())
        improvers.push_back(p.algo);
    for (const std::string& algo : improvers) {
      md << "P(" << algo << " improves on the baseline):\n\n| baseline | metric | n | P(improvement) [95% CI] |\n|---|---|---|---|\n";
      html << "<h3>P(" << algo << " improves on the baseline)</h3><table><tr><th>baseline</th><th>metric</th>"
              "<th>n (" << algo << ", baseline)</th><th>P(improvement) [95% CI]</th></tr>\n";
      for (const Pi& p : pis) {
        if (p.env != env || p.algo != algo) continue;
        const bool enough = std::min(p.nx, p.ny) >= kMinSeeds;
        const std::string pv = enough ? short_num(p.p) + " [" + short_num(p.ci.low) + ", " + short_num(p.ci.high) + "]"
                                      : no_stat(std::min(p.nx, p.ny), "P(improvement)");
        md << "| " << p.baseline << " | " << p.metric << " (" << (metric_info(p.metric).higher_better ? "higher" : "lower")
           << " is better) | " << p.nx << ", " << p.ny << " | " << pv << " |\n";
        html << "<tr><td class=\"l\">" << p.baseline << "</td><td class=\"l\">" << p.metric << "</td><td>" << p.nx
             << ", " << p.ny << "</td><td class=\""
             << (!enough ? "na" : p.p > 0.5 ? "good" : p.p < 0.5 ? "bad" : "") << "\">" << pv << "</td></tr>\n";
      }
      md << "\n";
      html << "</table>\n";
    }
  }
  write_shelf_real(d, shelf, out("shelf_real.csv"), md, html);
  md << "## Final vs best evaluation\n\n| run | final return | best return (at env steps) | final distance | best "
        "distance | fell far |\n|---|---|---|---|---|---|\n";
  html << "<h2>Final vs best evaluation</h2><table><tr><th>run</th><th>final return</th><th>best return</th>"
          "<th>best at env steps</th><th>final distance</th><th>best distance</th><th>fell far below best</th></tr>\n";
  for (const Drop& x : dr) {
    md << "| " << x.run->cell.name() << " | " << short_num(x.final_ret) << " | " << short_num(x.best_ret) << " ("
       << short_num(x.best_steps) << ") | " << short_num(x.final_dist) << " | " << short_num(x.best_dist) << " | "
       << (x.dropped ? "**yes**" : "no") << " |\n";
    html << "<tr" << (x.dropped ? " class=\"bad\"" : "") << "><td class=\"l\">" << x.run->cell.name() << "</td><td>"
         << short_num(x.final_ret) << "</td><td>" << short_num(x.best_ret) << "</td><td>" << short_num(x.best_steps)
         << "</td><td>" << short_num(x.final_dist) << "</td><td>" << short_num(x.best_dist) << "</td><td>"
         << (x.dropped ? "yes" : "no") << "</td></tr>\n";
  }
  html << "</table>\n";
  md << "\n## Missing or failed runs\n\n";
  html << "<h2>Missing or failed runs</h2>\n";
  if (res.missing.empty()) {
    md << "None: every run of the spec finished.\n";
    html << "<p>None: every run of the spec finished.</p>\n";
  } else {
    md << "| run | state | log |\n|---|---|---|\n";
    html << "<table><tr><th>run</th><th>state</th><th>log</th></tr>\n";
    for (const ReportRun& r : d.runs) {
      if (r.finished) continue;
      md << "| " << r.cell.name() << " | " << r.state << " | " << r.log << " |\n";
      html << "<tr class=\"bad\"><td class=\"l\">" << r.cell.name() << "</td><td class=\"l\">" << r.state
           << "</td><td class=\"l\">" << html_escape(r.log) << "</td></tr>\n";
    }
    html << "</table>\n";
  }
  html << "<p class=\"note\">Files: summary.csv, time_to_target.csv, summary.md, prob_improvement.csv, "
          "final_vs_best.csv, missing.csv, shelf_real.csv (a sweep with shelf runs), claims.csv (a sweep with the "
          "paper's cells) and "
          "the SVG figures beside this page.</p></body></html>\n";
  write_file_atomic(out("summary.md"), md.str());
  write_file_atomic(res.index_html, html.str());
  return res;
}

}  // namespace atacom
