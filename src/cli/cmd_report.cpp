// atacom report DIR: statistics, figures and an HTML page of a sweep (src/experiments/).
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/experiments/report.hpp"

namespace atacom::cli {
namespace {

const RegisterCommand register_report{Command{
    "report", "statistics (IQM, bootstrap intervals, P(improvement)), figures and index.html of a sweep directory",
    [](CLI::App& app) -> std::function<int()> {
      auto o = std::make_shared<ReportOptions>();
      app.add_option("DIR", o->dir, "sweep directory (atacom sweep --out)")->required();
      add_number_flag(app, "--resamples", o->resamples, range::closed(100, 1000000),
                      "bootstrap resamples of the tables' intervals");
      add_number_flag(app, "--curve-resamples", o->curve_resamples, range::closed(10, 100000),
                      "bootstrap resamples per learning-curve point");
      add_number_flag(app, "--bootstrap-seed", o->seed, seed_range<uint64_t>(), "bootstrap seed");
      auto seeds = std::make_shared<std::string>();
      app.add_option("--seeds", *seeds,
                     "only these seeds' cells, e.g. 0-4 or 0,2,5 (the report goes to DIR/report-seeds-<list>)");
      app.add_option("--claims", o->claims,
                     "the paper's claims to check (claims.csv): a claims file, or none; default: the shipped "
                     "data/paper_claims.json");
      return [o, seeds]() {
        if (!seeds->empty()) o->seeds = parse_seed_list(*seeds);
        const ReportResult r = write_report(*o);
        std::cout << "report: " << r.finished << " of " << r.runs << " runs finished";
        if (!r.missing.empty()) std::cout << " (" << r.missing.size() << " missing or failed: listed in the report)";
        if (!r.dropped.empty()) std::cout << "; " << r.dropped.size() << " runs ended far below their best evaluation";
        if (r.claims) std::cout << "; the paper's claims checked (claims.csv)";
        std::cout << "\n" << r.index_html << "\n";
        return 0;
      };
    }}};

}  // namespace
}  // namespace atacom::cli
