#include "src/safety/filter.hpp"

#include <istream>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"
#include "src/core/config_json.hpp"
#include "src/safety/filter_json.hpp"
#include "src/safety/filter_safelayer.hpp"

namespace atacom {

namespace {

using nlohmann::json;
using namespace filter_json;

json status_flags(uint32_t st) {
  json f = json::array();
  if (st & kStatusBiasOutOfBounds) f.push_back("bias_out_of_bounds");
  if (st & kStatusAlphaNonFinite) f.push_back("alpha_nonfinite");
  if (st & kStatusModelNonFinite) f.push_back("model_nonfinite");
  if (st & kStatusEqualityRankLoss) f.push_back("equality_rank_loss");
  return f;
}

json process(const json& j) {
  if (!j.is_object()) fail("expected a JSON object");
  static const char* known[] = {"f", "G", "J_q", "c", "alpha", "J_x", "xdot", "slack", "beta",
                                "tol", "K_c", "basis", "bounds", "equality", "id", "method", "dt", "threshold",
                                "gamma"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    bool ok = false;
    for (const char* kname : known) ok = ok || it.key() == kname;
    if (!ok) fail("unknown key '" + printable_text(it.key()) + "'");
  }
  for (const char* req : {"f", "G", "J_q", "c", "alpha"})
    if (!j.contains(req)) fail(std::string("missing key '") + req + "'");
  if (j.contains("J_x") != j.contains("xdot")) fail("'J_x' and 'xdot' must be given together");
  const std::string method = filter_method(j);

  const std::vector<double> f = vec(j, "f");
  const std::vector<double> alpha = vec(j, "alpha");
  const std::vector<double> c = vec(j, "c");
  const int n = static_cast<int>(f.size()), m = static_cast<int>(alpha.size()), k = static_cast<int>(c.size());
  if (n < 1) fail("'f' must not be empty (it sets n)");
  if (m < 1) fail("'alpha' must not be empty (it sets m)");
  const std::vector<double> xdot = j.contains("xdot") ? vec(j, "xdot") : std::vector<double>{};
  const int p = static_cast<int>(xdot.size());

  ProjectorModel model = default_projector_model(n, m, k, p);
  model.slack = per_row<SlackType>(j, "slack", k, SlackType::SoftCorner, [](const json& v, const std::string& what) {
    if (!v.is_string()) fail("'" + what + "' must be a string");
    return parse_slack_type(v.get<std::string>());
  });
  model.beta = per_row<double>(j, "beta", k, 3.0, number);
  model.tol = per_row<double>(j, "tol", k, 1e-6, number);
  model.equality = per_row<uint8_t>(j, "equality", k, 0, [](const json& v, const std::string& what) -> uint8_t {
    if (!v.is_boolean()) fail("'" + what + "' must be true or false");
    return v.get<bool>() ? 1 : 0;
  });
  if (j.contains("K_c")) model.K_c = number(j.at("K_c"), "K_c");
  if (j.contains("bounds")) {
    if (!j.at("bounds").is_string()) fail("'bounds' must be \"correction_first\" or \"tangent_scale\"");
    model.bounds = parse_bound_rule(j.at("bounds").get<std::string>());
  }
  if (j.contains("basis")) {
    if (!j.at("basis").is_string()) fail("'basis' must be \"projected\" or \"smooth\"");
    model.basis = parse_basis_type(j.at("basis").get<std::string>());
  }
  model.validate();

  ProjectorBatch B(model, 1);
  B.f = f;
  B.G = mat(j, "G", n, m, "n x m");
  B.Jq = k ? mat(j, "J_q", k, n, "k x n") : std::vector<double>{};
  if (!k && !(j.at("J_q").is_array() && j.at("J_q").empty())) fail("'J_q' must be [] when 'c' is empty");
  B.c = c;
  if (j.contains("J_x")) {  // validated even when p = 0 (then k rows of [])
    std::vector<double> Jx = k ? mat(j, "J_x", k, p, "k x p") : std::vector<double>{};
    if (!k && !(j.at("J_x").is_array() && j.at("J_x").empty())) fail("'J_x' must be [] when 'c' is empty");
    if (p > 0) {
      B.xdot = xdot;
      B.Jx = std::move(Jx);
    }
  }
  B.alpha = alpha;
  if (method != "atacom") return safelayer_filter(j, model, B);  // safelayer, cbf
  project_batch(model, B, {.store_basis = false, .parallel = false});

  std::vector<double> qdot(n);
  for (int i = 0; i < n; ++i) {
    double v = f[i];
    for (int jj = 0; jj < m; ++jj) v += B.G[size_t(i) * m + jj] * B.a[jj];
    qdot[i] = v;
  }
  json out = {{"a", B.a}, {"qdot", qdot}, {"s", B.s}, {"lambda", B.lambda[0]}, {"status", B.status[0]},
              {"status_flags", status_flags(B.status[0])}};
  if (j.contains("id")) out["id"] = j.at("id");
  return out;
}

}  // namespace

namespace {

json error_object(long line_number, const std::string& msg) {
  return {{"error", "line " + std::to_string(line_number) + ": " + msg}, {"line", line_number}};
}

// Dumps never throw: parsed strings are valid UTF-8 and messages are printable_text.
std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// One line of at most `max_bytes` bytes kept ('\n' excluded, a trailing '\r'
// kept for the JSON parser to skip as whitespace); `length` is the whole
// line's. Returns false at the end of the input.
bool read_line(std::streambuf& sb, std::string& line, size_t max_bytes, size_t& length) {
  line.clear();
  length = 0;
  bool any = false;
  for (int c; (c = sb.sbumpc()) != std::char_traits<char>::eof();) {
    any = true;
    if (c == '\n') return true;
    if (length < max_bytes) line.push_back(static_cast<char>(c));
    ++length;
  }
  return any;
}

}  // namespace

bool filter_line(const std::string& line, long line_number, std::string& out) {
  json in;
  try {
    if (line.find_first_not_of(" \t\r") == std::string::npos) {
      out = dump(error_object(line_number, "blank line (expected one JSON object per line)"));
      return false;
    }
    try {
      in = parse_json_strict(line, "request");
    } catch (const std::invalid_argument& e) {
      out = dump(error_object(line_number, e.what()));
      return false;
    }
    out = dump(process(in));
    return true;
  } catch (const std::exception& e) {
    json err = error_object(line_number, printable_text(e.what(), 1000));
    if (in.is_object() && in.contains("id")) err["id"] = in.at("id");
    out = dump(err);
    return false;
  }
}

long run_filter(std::istream& in, std::ostream& out, size_t max_line_bytes) {
  std::string line, result;
  long number = 0, failed = 0;
  size_t length = 0;
  std::streambuf* sb = in.rdbuf();
  while (sb && read_line(*sb, line, max_line_bytes, length)) {
    ++number;
    bool ok;
    if (length > max_line_bytes) {
      ok = false;
      result = dump(error_object(number, "line of " + std::to_string(length) + " bytes, longer than the limit of " +
                                             std::to_string(max_line_bytes) + " (--max-line-bytes)"));
    } else {
      ok = filter_line(line, number, result);
    }
    if (!ok) ++failed;
    out << result << '\n';
    out.flush();
    if (!out) throw std::runtime_error("cannot write the answer to line " + std::to_string(number) + " (output error)");
  }
  return failed;
}

}  // namespace atacom
