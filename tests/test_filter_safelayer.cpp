// `atacom filter` with "method": "safelayer": the pinned keys and outputs.
#include <catch2/catch.hpp>

#include <string>

#include <nlohmann/json.hpp>

#include "src/safety/filter.hpp"

using nlohmann::json;

namespace {
json filter_text_line(const std::string& line, bool* ok = nullptr) {
  std::string out;
  const bool r = atacom::filter_line(line, 1, out);
  if (ok) *ok = r;
  return json::parse(out);
}
}  // namespace

TEST_CASE("filter safelayer: one row active, the box inactive (Dalal's closed form)", "[filter]") {
  bool ok = false;
  // -0.01 + 0.1 (a_0 + 0.05) <= 0  ->  a_0 <= 0.05; a_pi = (1, 0.5).
  const json r = filter_text_line(R"({"method":"safelayer","dt":0.1,"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0],[0,1]],
      "c":[-0.01,-5],"J_x":[[1],[0]],"xdot":[0.05],"alpha":[1,0.5],"id":7})", &ok);
  REQUIRE(ok);
  CHECK(r["a"][0].get<double>() == Approx(0.05).margin(1e-12));
  CHECK(r["a"][1].get<double>() == Approx(0.5).margin(1e-12));
  CHECK(r["qdot"][0].get<double>() == Approx(0.05).margin(1e-12));
  CHECK(r["active"] == json::array({0}));
  CHECK(r["status"] == 0);
  CHECK(r["status_flags"] == json::array());
  CHECK(r["iterations"] == 1);
  CHECK(r["correction"].get<double>() == Approx(0.95).margin(1e-12));
  CHECK(r["id"] == 7);
}

TEST_CASE("filter safelayer: defaults (dt 1/30, threshold 0), alpha clipped, per-row threshold", "[filter]") {
  // Far inside: a = clip(alpha) = (1, -1), nothing active.
  json r = filter_text_line(R"({"method":"safelayer","f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-1],"alpha":[3,-2]})");
  CHECK(r["a"] == json::array({1.0, -1.0}));
  CHECK(r["active"] == json::array());
  // c + dt a_0 <= C with c = -0.02, dt = 1/30, C = -0.01: a_0 <= 0.3.
  r = filter_text_line(R"({"method":"safelayer","f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-0.02],"alpha":[1,0],
      "threshold":[-0.01]})");
  CHECK(r["a"][0].get<double>() == Approx(0.3).margin(1e-12));
  r = filter_text_line(R"({"method":"safelayer","f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-0.02],"alpha":[1,0],
      "threshold":-0.01})");
  CHECK(r["a"][0].get<double>() == Approx(0.3).margin(1e-12));
}

TEST_CASE("filter safelayer: the box is part of the QP (two rows and a bound active)", "[filter]") {
  // a_0 + a_1 <= 0 (dt = 1, c = 0); a_pi = (1, 1) -> projection (0, 0). With
  // a_0 - a_1 <= -1.5 as well, the solution (-0.75, 0.75) of the two rows is
  // in the box; with -1.9 it would be (-0.95, 0.95), also in the box; and
  // a_0 <= -1.2 forces the bound a_0 = -1 (infeasible: least violation).
  json r = filter_text_line(R"({"method":"safelayer","dt":1,"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,1],[1,-1]],"c":[0,1.5],
      "alpha":[1,1]})");
  CHECK(r["a"][0].get<double>() == Approx(-0.75).margin(1e-10));
  CHECK(r["a"][1].get<double>() == Approx(0.75).margin(1e-10));
  CHECK(r["active"] == json::array({0, 1}));
  r = filter_text_line(R"({"method":"safelayer","dt":1,"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[1.2],"alpha":[0.3,0.4]})");
  CHECK(r["a"][0].get<double>() == Approx(-1.0).margin(1e-12));
  CHECK(r["a"][1].get<double>() == Approx(0.4).margin(1e-12));
  CHECK(r["status_flags"] == json::array({"infeasible"}));
  CHECK(r["active"] == json::array({0}));
}

TEST_CASE("filter safelayer: bad keys are refused by name", "[filter]") {
  const struct { const char* line; const char* expect; } cases[] = {
      {R"({"method":"safelayer","dt":0,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})", "'dt' must be > 0"},
      {R"({"method":"safelayer","dt":"x","f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})", "'dt' must be a number"},
      {R"({"method":"safelayer","threshold":[0,0],"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
       "'threshold' has 2 entries"},
      {R"({"method":"safelayer","beta":3,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})", "'beta' is an ATACOM key"},
      {R"({"dt":0.1,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})", "'dt' needs \"method\": \"safelayer\""},
      {R"({"method":"qp","f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})", "'method' must be"},
  };
  for (const auto& tc : cases) {
    bool ok = true;
    const json r = filter_text_line(tc.line, &ok);
    INFO(tc.line);
    CHECK_FALSE(ok);
    CHECK_THAT(r["error"].get<std::string>(), Catch::Contains(tc.expect));
  }
  // the default method is still ATACOM, and says so explicitly too
  bool ok = false;
  const json r = filter_text_line(R"({"method":"atacom","f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0.5]})", &ok);
  CHECK(ok);
  CHECK(r.contains("lambda"));
}
