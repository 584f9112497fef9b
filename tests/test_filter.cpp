#include <catch2/catch.hpp>

#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/safety/filter.hpp"
#include "tests/shell_run.hpp"

using nlohmann::json;

namespace {
json run(const std::string& line, bool* ok = nullptr) {
  std::string out;
  const bool r = atacom::filter_line(line, 1, out);
  if (ok) *ok = r;
  return json::parse(out);
}
}  // namespace

TEST_CASE("filter: a valid line gives a, qdot, s, lambda, status", "[filter]") {
  bool ok = false;
  const json r = run(R"({"f":[0.1,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-2.0],"alpha":[0.5,-0.5],"id":"x"})", &ok);
  REQUIRE(ok);
  REQUIRE(r["a"].size() == 2);
  REQUIRE(r["qdot"].size() == 2);
  REQUIRE(r["s"].size() == 1);
  CHECK(r["s"][0].get<double>() == 2.0);
  CHECK(r["id"] == "x");
  CHECK(r["status"] == 0);
  // qdot = f + G a
  CHECK(r["qdot"][0].get<double>() == Approx(0.1 + r["a"][0].get<double>()));
  // far from the boundary the action passes nearly unchanged
  CHECK(r["a"][1].get<double>() == Approx(-0.5).margin(1e-3));
}

TEST_CASE("filter: options (slack per row, smooth basis, equality, J_x)", "[filter]") {
  bool ok = false;
  const json r = run(R"({"f":[0,0,0],"G":[[1,0],[0,1],[0,0]],"J_q":[[1,0,0],[0,1,0]],"c":[-0.5,0.0],
      "alpha":[1,1],"beta":[3,5],"tol":1e-4,"slack":["quadratic","exponential"],"basis":"smooth",
      "K_c":10,"J_x":[[0],[1]],"xdot":[0.2],"equality":[false,true]})", &ok);
  REQUIRE(ok);
  // the equality row holds to first order: dc1/dt = a_1 + 0.2 = -K_c c1 = 0
  CHECK(r["a"][1].get<double>() == Approx(-0.2).margin(1e-9));
}

TEST_CASE("filter: a correction outside the box is scaled (default) or returned as is (bounds)", "[filter]") {
  // c = 0.1 with K_c 30: b = -3 along the row, far outside the box.
  const std::string base = R"("f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,1]],"c":[0.1],"alpha":[1,-1])";
  bool ok = false;
  const json first = run("{" + base + "}", &ok);
  REQUIRE(ok);
  CHECK(first["status"] == 1);
  CHECK(first["a"][0].get<double>() == Approx(-1.0));
  CHECK(first["a"][1].get<double>() == Approx(-1.0));
  const json old = run("{" + base + R"(,"bounds":"tangent_scale"})", &ok);
  REQUIRE(ok);
  CHECK(old["a"][0].get<double>() == Approx(-1.5));
  CHECK(old["a"][1].get<double>() == Approx(-1.5));
  const json bad = run("{" + base + R"(,"bounds":"clip"})", &ok);
  CHECK_FALSE(ok);
  CHECK(bad["error"].get<std::string>().find("unknown bound rule 'clip'") != std::string::npos);
}

TEST_CASE("filter: malformed lines give an error naming the problem", "[filter]") {
  const struct { const char* line; const char* expect; } cases[] = {
      {"{not json", "not valid JSON"},
      {R"({"f":[0,0],"G":[[1,0]],"J_q":[[1,0]],"c":[-1],"alpha":[1,0]})", "'G' must be 2 x 2"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-1]})", "missing key 'alpha'"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"Jq":[[1,0]],"c":[-1],"alpha":[0,0]})", "unknown key 'Jq'"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[1e999],"alpha":[0,0]})", "overflow"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-1],"alpha":[0,0],"beta":-1})", "beta"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-1],"alpha":[0,0],"slack":"cubic"})", "unknown slack"},
      {R"({"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-1],"alpha":[0,0],"J_x":[[1]]})", "together"},
      {R"([1,2,3])", "expected a JSON object"},
  };
  for (const auto& c : cases) {
    bool ok = true;
    const json r = run(c.line, &ok);
    INFO(c.line << " -> " << r.dump());
    CHECK_FALSE(ok);
    CHECK(r["error"].get<std::string>().find(c.expect) != std::string::npos);
  }
}

TEST_CASE("filter: the stream goes on after an error and counts failures", "[filter]") {
  std::istringstream in(
      "{\"f\":[0],\"G\":[[1]],\"J_q\":[[1]],\"c\":[-1],\"alpha\":[1]}\n"
      "garbage\n"
      "\n"
      "{\"f\":[0],\"G\":[[1]],\"J_q\":[[1]],\"c\":[-1],\"alpha\":[0.5]}\n");
  std::ostringstream out;
  CHECK(atacom::run_filter(in, out) == 2);  // the garbage line and the blank line
  std::istringstream lines(out.str());
  std::string l;
  std::vector<json> results;
  while (std::getline(lines, l)) results.push_back(json::parse(l));
  REQUIRE(results.size() == 4);  // one answer per line, a blank line included
  CHECK(results[0].contains("a"));
  CHECK(results[1]["line"] == 2);
  CHECK(results[2]["line"] == 3);
  CHECK(results[3].contains("a"));
}

TEST_CASE("filter: the atacom executable streams and exits nonzero after a failure", "[filter]") {
  const std::string cmd = std::string("printf '%s\\n' '{\"f\":[0],\"G\":[[1]],\"J_q\":[[1]],\"c\":[-1],\"alpha\":[1]}' "
                                      "'oops' | ") + ATACOM_ATACOM_EXE + " filter 2>/dev/null";
  const ShellResult r = run_shell(cmd);
  CHECK(r.rc == 1);
  CHECK(r.out.find("\"a\"") != std::string::npos);
  CHECK(r.out.find("\"error\"") != std::string::npos);
}
