// The paper's claims checked against a sweep's runs, in the sweep report:
// claims.csv and the first section of summary.md and index.html. The claims
// are data (data/paper_claims.json, or ReportOptions::claims): each is a few
// checks, each check one number of the report read against a rule:
//   better       P(algo improves on baseline) on a report metric: holds when
//                its 95 % interval lies above 0.5, does not hold when below,
//                not separable when the interval holds 0.5
//   zero         every finished run's value is 0
//   paper_value  ours (IQM, 95 % interval) against the paper's number: holds
//                unless the interval lies wholly on the worse side of it
// Metrics are report metrics (summary.json keys) or, for zero and
// paper_value, the ShelfEnvReal protocol's per-policy numbers
// shelf_real.success_1/2, shelf_real.error_1/2, shelf_real.collisions.
// Internal to src/experiments/.
#pragma once
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/experiments/report_data.hpp"
#include "src/experiments/report_shelf_real.hpp"

namespace atacom {

struct ClaimCheck {
  std::string kind;  // better | zero | paper_value
  std::string env, metric, algo;
  std::string baseline;      // better only
  double paper_value = 0.0;  // paper_value only
};

struct Claim {
  std::string id, claim, paper;  // paper: the paper's number or statement
  std::vector<ClaimCheck> checks;
};

// The claims of a claims document ({"about": ..., "claims": [...]}). Throws
// std::invalid_argument naming the key ("claims[3].checks[0].metric") and
// what it allows; `what` names the file.
std::vector<Claim> parse_claims(const nlohmann::json& doc, const std::string& what);

// Writes claims.csv (one row per check) and the section, and returns true;
// returns false and writes nothing when no check's env and algorithms are
// in the sweep (a sweep unrelated to the paper). `shelf` is the report's
// ShelfEnvReal section (its numbers feed the shelf_real.* metrics).
bool write_claims(const ReportData& d, const ShelfRealSection& shelf, const std::vector<Claim>& claims,
                  const std::string& csv_path, std::ostream& md, std::ostream& html);

}  // namespace atacom
