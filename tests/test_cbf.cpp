// The CBF-QP safety layer (src/safety/cbf_env.hpp): `atacom filter` with
// "method": "cbf" against an independent QP (enumerated active sets, in the
// CBF's own units) and the KKT conditions on random feasible problems; the
// infeasible flag with the least squared violation; the layer in the table
// (cbf-sac, its "cbf" section); gamma = 1/dt is SafeLayer bit for bit.
// (A smaller gamma lets a row close less of its distance per step: the
// filter cases below pin a_0 <= gamma |c| directly.)
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "atacom/safelayer.hpp"
#include "atacom/trainer.hpp"
#include "src/safety/cbf_env.hpp"
#include "src/safety/filter.hpp"
#include "train/algorithms.hpp"

using nlohmann::json;
using namespace atacom;

namespace {

json run_line(const json& in, bool* ok = nullptr) {
  std::string out;
  const bool r = filter_line(in.dump(), 1, out);
  if (ok) *ok = r;
  return json::parse(out);
}

// One CBF problem in the user's terms.
struct Cbf {
  int n = 0, m = 0, k = 0, p = 0;
  Eigen::VectorXd f, c, xdot, alpha;
  Eigen::MatrixXd G, Jq, Jx;
  double gamma = 10;
  // The rows as A a <= b: A = J_q G, b = -gamma c - J_q f - J_x xdot.
  Eigen::MatrixXd A() const { return Jq * G; }
  Eigen::VectorXd b() const {
    Eigen::VectorXd r = -gamma * c - Jq * f;
    if (p) r -= Jx * xdot;
    return r;
  }
  json request() const {
    auto vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    auto mat = [](const Eigen::MatrixXd& M) {
      json rows = json::array();
      for (int i = 0; i < M.rows(); ++i) {
        std::vector<double> r(size_t(M.cols()));
        for (int j = 0; j < M.cols(); ++j) r[size_t(j)] = M(i, j);
        rows.push_back(r);
      }
      return rows;
    };
    json j = {{"method", "cbf"}, {"gamma", gamma}, {"f", vec(f)}, {"G", mat(G)}, {"J_q", mat(Jq)}, {"c", vec(c)},
              {"alpha", vec(alpha)}};
    if (p) j["J_x"] = mat(Jx), j["xdot"] = vec(xdot);
    return j;
  }
};

// Random rows, feasible by construction at a point a0 inside the box: c is
// set so that row i holds at a0 with a random margin (c may be positive: a
// violated row the CBF still lets recover).
Cbf random_feasible(Rng& rng, int n, int m, int k, int p) {
  Cbf q;
  q.n = n, q.m = m, q.k = k, q.p = p;
  q.gamma = rng.uniform(0.5, 40.0);
  auto rnd = [&](int r, int c) {
    Eigen::MatrixXd M(r, c);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < c; ++j) M(i, j) = rng.normal();
    return M;
  };
  q.f = rnd(n, 1).col(0) * 0.3;
  q.G = rnd(n, m);
  q.Jq = rnd(k, n);
  q.Jx = rnd(k, p);
  q.xdot = rnd(p, 1).col(0) * 0.5;
  Eigen::VectorXd a0(m);
  for (int j = 0; j < m; ++j) a0(j) = rng.uniform(-0.9, 0.9);
  Eigen::VectorXd lhs = q.Jq * (q.f + q.G * a0);
  if (p) lhs += q.Jx * q.xdot;
  q.c.resize(k);
  for (int i = 0; i < k; ++i) q.c(i) = -(lhs(i) + rng.uniform(0.0, 0.5)) / q.gamma;
  q.alpha.resize(m);
  for (int j = 0; j < m; ++j) q.alpha(j) = rng.uniform(-1.3, 1.3);  // clipped to the box first
  return q;
}

// The independent QP: min 1/2 |a - a_pi|^2 s.t. A a <= b, -1 <= a <= 1, by
// trying every set of at most m constraints as equalities; the feasible
// stationary point with non-negative multipliers of least distance.
bool enumerate_qp(const Eigen::MatrixXd& A0, const Eigen::VectorXd& b0, const Eigen::VectorXd& api, Eigen::VectorXd& best) {
  const int k = int(A0.rows()), m = int(api.size()), M = k + 2 * m;
  Eigen::MatrixXd A(M, m);
  Eigen::VectorXd b(M);
  A.topRows(k) = A0;
  b.head(k) = b0;
  A.middleRows(k, m) = Eigen::MatrixXd::Identity(m, m);
  A.bottomRows(m) = -Eigen::MatrixXd::Identity(m, m);
  b.tail(2 * m).setOnes();
  double best_d = INFINITY;
  for (uint32_t mask = 0; mask < (1u << M); ++mask) {
    if (__builtin_popcount(mask) > m) continue;
    std::vector<int> S;
    for (int i = 0; i < M; ++i)
      if (mask >> i & 1) S.push_back(i);
    Eigen::VectorXd a = api;
    if (!S.empty()) {
      Eigen::MatrixXd AS(S.size(), m);
      Eigen::VectorXd bS(S.size());
      for (size_t t = 0; t < S.size(); ++t) AS.row(Eigen::Index(t)) = A.row(S[t]), bS(Eigen::Index(t)) = b(S[t]);
      Eigen::FullPivLU<Eigen::MatrixXd> lu(AS * AS.transpose());
      if (lu.rank() < int(S.size())) continue;
      const Eigen::VectorXd mu = lu.solve(AS * api - bS);
      if (mu.minCoeff() < -1e-12) continue;
      a = api - AS.transpose() * mu;
    }
    if ((A * a - b).maxCoeff() > 1e-9 * (1 + b.cwiseAbs().maxCoeff())) continue;
    const double d = (a - api).squaredNorm();
    if (d < best_d) best_d = d, best = a;
  }
  return std::isfinite(best_d);
}

Eigen::VectorXd clip(const Eigen::VectorXd& v) { return v.cwiseMax(-1.0).cwiseMin(1.0); }

Eigen::VectorXd from_json(const json& j) {
  Eigen::VectorXd v(Eigen::Index(j.size()));
  for (size_t i = 0; i < j.size(); ++i) v(Eigen::Index(i)) = j[i].get<double>();
  return v;
}

}  // namespace

TEST_CASE("cbf filter: the exact QP of the CBF rows and the box on random feasible problems (KKT, independent QP)",
          "[cbf]") {
  Rng rng(32, 1);
  int corrected = 0, bound_active = 0;
  for (int trial = 0; trial < 600; ++trial) {
    const int m = 1 + trial % 3, n = m + int(rng.uniform() * 3), k = 1 + int(rng.uniform() * 6), p = trial % 2;
    const Cbf q = random_feasible(rng, n, m, k, p);
    INFO("trial " << trial << " n " << n << " m " << m << " k " << k << " p " << p << " gamma " << q.gamma);
    bool ok = false;
    const json r = run_line(q.request(), &ok);
    REQUIRE(ok);
    REQUIRE(r["status"] == 0);
    REQUIRE(r["status_flags"] == json::array());
    const Eigen::VectorXd a = from_json(r["a"]), api = clip(q.alpha);
    const Eigen::MatrixXd A = q.A();
    const Eigen::VectorXd b = q.b(), resid = A * a - b;
    const double scale = 1 + b.cwiseAbs().maxCoeff() + A.cwiseAbs().maxCoeff();
    // primal feasibility: the rows in the CBF's units, and the box
    REQUIRE(resid.maxCoeff() <= 1e-8 * scale);
    REQUIRE(a.cwiseAbs().maxCoeff() <= 1.0);
    // qdot = f + G a
    CHECK((from_json(r["qdot"]) - (q.f + q.G * a)).norm() <= 1e-12 * (1 + q.f.norm() + q.G.norm()));
    // stationarity with non-negative multipliers on the active set: a_pi - a = sum mu_i grad_i
    std::vector<Eigen::VectorXd> act;
    for (int i = 0; i < k; ++i)
      if (resid(i) >= -1e-7 * scale) act.push_back(A.row(i).transpose());
    for (int j = 0; j < m; ++j) {
      if (a(j) >= 1.0 - 1e-12) act.push_back(Eigen::VectorXd::Unit(m, j)), ++bound_active;
      if (a(j) <= -1.0 + 1e-12) act.push_back(-Eigen::VectorXd::Unit(m, j)), ++bound_active;
    }
    const Eigen::VectorXd d = api - a;
    if (d.norm() > 1e-12) {
      ++corrected;
      REQUIRE(!act.empty());
      Eigen::MatrixXd N(m, Eigen::Index(act.size()));
      for (size_t t = 0; t < act.size(); ++t) N.col(Eigen::Index(t)) = act[t];
      // least-squares multipliers, then the non-negative ones by NNLS-free check:
      // the stationarity residual of the best non-negative combination is ~0
      const Eigen::VectorXd mu = N.completeOrthogonalDecomposition().solve(d);
      CHECK((N * mu - d).norm() <= 1e-7 * (1 + d.norm()));
      if (N.fullPivLu().rank() == N.cols()) CHECK(mu.minCoeff() >= -1e-7 * (1 + mu.cwiseAbs().maxCoeff()));
    }
    // the same point as the independent QP
    Eigen::VectorXd ref;
    REQUIRE(enumerate_qp(A, b, api, ref));
    CHECK((a - ref).norm() <= 1e-7 * (1 + ref.norm()));
    // the reported active rows are the rows at their bound
    for (const auto& i : r["active"]) CHECK(std::abs(resid(i.get<int>())) <= 1e-7 * scale);
  }
  CHECK(corrected > 200);    // most problems are not solved by a_pi
  CHECK(bound_active > 20);  // and the box takes part
}

TEST_CASE("cbf filter: infeasible rows give the least squared violation and the flag, keys and defaults", "[cbf]") {
  // a_0 <= -2 (gamma c = 2: J_q G a <= -2 with G = I) and -a_0 <= -0.5: no action satisfies both;
  // the least squared violation over the box: (a + 2)^2 + (0.5 - a)^2 -> a = -0.75 (inside the box).
  bool ok = false;
  json r = run_line(json::parse(R"({"method":"cbf","gamma":1,"f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0],[-1,0]],
      "c":[2,0.5],"alpha":[1,0.3]})"), &ok);
  REQUIRE(ok);
  CHECK(r["status"] == 1);
  CHECK(r["status_flags"] == json::array({"infeasible"}));
  CHECK(r["a"][0].get<double>() == Approx(-0.75).margin(1e-9));
  CHECK(r["a"][1].get<double>() == Approx(0.3).margin(1e-9));  // the closest to a_pi among the minimisers
  // A row no action in the box meets: a_0 <= -1.5 -> the bound a_0 = -1.
  r = run_line(json::parse(R"({"method":"cbf","gamma":3,"f":[0],"G":[[1]],"J_q":[[1]],"c":[0.5],"alpha":[0.2]})"));
  CHECK(r["status_flags"] == json::array({"infeasible"}));
  CHECK(r["a"][0].get<double>() == Approx(-1.0).margin(1e-12));
  // Default gamma 10: c = -0.01 allows cdot <= 0.1, so a_0 <= 0.1 (G = I).
  r = run_line(json::parse(R"({"method":"cbf","f":[0,0],"G":[[1,0],[0,1]],"J_q":[[1,0]],"c":[-0.01],"alpha":[1,0.5]})"));
  CHECK(r["a"][0].get<double>() == Approx(0.1).margin(1e-12));
  CHECK(r["a"][1].get<double>() == Approx(0.5).margin(1e-12));
  CHECK(r["active"] == json::array({0}));
  for (const char* key : {"a", "qdot", "active", "correction", "iterations", "status", "status_flags"})
    CHECK(r.contains(key));
  // The moving obstacle's term: J_x xdot = 0.05 uses part of the allowance.
  r = run_line(json::parse(R"({"method":"cbf","f":[0],"G":[[1]],"J_q":[[1]],"c":[-0.01],"J_x":[[1]],"xdot":[0.05],
      "alpha":[1]})"));
  CHECK(r["a"][0].get<double>() == Approx(0.05).margin(1e-12));
  // Keys of the other methods are refused, and gamma must be > 0.
  for (const char* bad : {R"({"method":"cbf","dt":0.1,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
                          R"({"method":"cbf","slack":"quadratic","f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
                          R"({"method":"safelayer","gamma":1,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
                          R"({"gamma":1,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
                          R"({"method":"cbf","gamma":0,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})",
                          R"({"method":"cbf","gamma":-2,"f":[0],"G":[[1]],"J_q":[[1]],"c":[-1],"alpha":[0]})"}) {
    INFO(bad);
    r = run_line(json::parse(bad), &ok);
    CHECK(!ok);
    CHECK(r.contains("error"));
  }
}

TEST_CASE("cbf layer: in the table as cbf-sac, la-cbf, ..., its section, gamma = 1/dt is SafeLayer", "[cbf]") {
  const Algorithm& a = find_algorithm("cbf-sac");
  CHECK(a.safety == SafetyLayer::parse("cbf"));
  CHECK(a.learner == "sac");
  CHECK(find_algorithm("la-cbf").source == ActionSource::Attractor);
  // The run config holds the resolved "cbf" section; overrides and bad values name the key.
  RunConfig rc = resolve_run_config({{"train", {{"env", "table"}, {"algo", "cbf-sac"}}}});
  CHECK(rc.safety == json({{"gamma", kCbfDefaultGamma}}));
  CHECK(run_config_json(rc)["cbf"]["gamma"] == kCbfDefaultGamma);
  rc = resolve_run_config({{"train", {{"env", "nav"}, {"algo", "cbf-sac"}}}, {"cbf", {{"gamma", 4}}}});
  CHECK(rc.safety["gamma"] == 4);
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "nav"}, {"algo", "sac"}}}, {"cbf", {{"gamma", 4}}}}),
                    Catch::Contains("does not apply"));
  CHECK_THROWS_WITH(resolve_run_config({{"train", {{"env", "nav"}, {"algo", "cbf-sac"}}}, {"cbf", {{"rate", 4}}}}),
                    Catch::Contains("cbf.rate"));
  CHECK_THROWS_WITH(make_env(EnvRequest{"nav", 2, SafetyLayer::parse("cbf"), json::object(), {{"gamma", -1.0}}}),
                    Catch::Contains("cbf.gamma"));
  // gamma = 30 is SafeLayer's one-period linearisation at 30 Hz: the same
  // controls, so the same trajectory, bit for bit.
  for (const char* env_name : {"table", "nav"}) {
    INFO(env_name);
    auto cbf = make_env(EnvRequest{env_name, 16, SafetyLayer::parse("cbf"), json::object(), {{"gamma", 30.0}}});
    auto sl = make_env(EnvRequest{env_name, 16, SafetyLayer::SafeLayer});
    REQUIRE(cbf->spec().dt == 1.0 / 30.0);
    cbf->seed(3);
    sl->seed(3);
    Rng rng(3, 9);
    std::vector<double> act(size_t(16) * cbf->spec().act_dim);
    int64_t corrected = 0;
    for (int t = 0; t < 300; ++t) {
      for (double& x : act) x = rng.uniform(-1.0, 1.0);
      cbf->step(act.data());
      sl->step(act.data());
      REQUIRE(cbf->buffers().obs == sl->buffers().obs);
      REQUIRE(cbf->buffers().constraints == sl->buffers().constraints);
      REQUIRE(cbf->buffers().info == sl->buffers().info);  // the same columns under other names
      const auto& c = dynamic_cast<const CbfEnv&>(*cbf).correction();
      for (double x : c.correction) corrected += x > 0;
    }
    CHECK(corrected > 0);
  }
}
