#include "src/safety/filter.hpp"

#include <cmath>
#include <istream>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "atacom/projector.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "src/safety/filter_safelayer.hpp"

namespace atacom {

namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& msg) { throw std::invalid_argument(msg); }

double number(const json& v, const std::string& what) {
  if (!v.is_number()) fail("'" + what + "' must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail("'" + what + "' is NaN or infinite");
  return x;
}

std::vector<double> vec(const json& j, const std::string& key, int expected = -1) {
  const json& v = j.at(key);
  if (!v.is_array()) fail("'" + key + "' must be an array of numbers");
  if (v.size() > size_t(limits::kFilterMaxDim))  // n, m, k, p: checked before the projector allocates
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, more than the limit of " +
         std::to_string(limits::kFilterMaxDim));
  if (expected >= 0 && static_cast<int>(v.size()) != expected)
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, expected " + std::to_string(expected));
  std::vector<double> out;
  out.reserve(v.size());
  for (size_t i = 0; i < v.size(); ++i) out.push_back(number(v[i], key + "[" + std::to_string(i) + "]"));
  return out;
}

// rows x cols matrix given as a list of rows; returns row-major data.
std::vector<double> mat(const json& j, const std::string& key, int rows, int cols, const std::string& shape) {
  const json& v = j.at(key);
  if (!v.is_array()) fail("'" + key + "' must be a list of rows");
  if (static_cast<int>(v.size()) != rows)
    fail("'" + key + "' must be " + std::to_string(rows) + " x " + std::to_string(cols) + " (" + shape + "), got " +
         std::to_string(v.size()) + " rows");
  std::vector<double> out;
  out.reserve(size_t(rows) * cols);
  for (int r = 0; r < rows; ++r) {
    const json& row = v[r];
    if (!row.is_array() || static_cast<int>(row.size()) != cols)
      fail("'" + key + "' must be " + std::to_string(rows) + " x " + std::to_string(cols) + " (" + shape + "), row " +
           std::to_string(r) + " has " + (row.is_array() ? std::to_string(row.size()) : std::string("no")) + " entries");
    for (int c = 0; c < cols; ++c)
      out.push_back(number(row[c], key + "[" + std::to_string(r) + "][" + std::to_string(c) + "]"));
  }
  return out;
}

template <class T, class Parse>
std::vector<T> per_row(const json& j, const std::string& key, int k, T dflt, Parse parse) {
  if (!j.contains(key)) return std::vector<T>(k, dflt);
  const json& v = j.at(key);
  if (!v.is_array()) return std::vector<T>(k, parse(v, key));
  if (static_cast<int>(v.size()) != k)
    fail("'" + key + "' has " + std::to_string(v.size()) + " entries, expected one per constraint (" +
         std::to_string(k) + ") or a single value");
  std::vector<T> out;
  for (size_t i = 0; i < v.size(); ++i) out.push_back(parse(v[i], key + "[" + std::to_string(i) + "]"));
  return out;
}

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
                                "tol", "K_c", "basis", "equality", "id", "method", "dt", "threshold"};
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
  if (method == "safelayer") return safelayer_filter(j, model, B);
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
