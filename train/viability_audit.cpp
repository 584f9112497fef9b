#include "train/viability_audit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <vector>

#include <Eigen/Dense>

#include "atacom/control_affine_env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/policy.hpp"
#include "atacom/rng.hpp"
#include "atacom/safelayer.hpp"
#include "src/core/projector_reference.hpp"
#include "train/policy_source.hpp"

namespace atacom {

namespace {

constexpr int kHistory = 3;  // previous steps kept per env

// One env's projector inputs as the reference wants them.
ReferenceInput reference_input(const ProjectorModel& pm, const ProjectorBatch& pb, int e) {
  const int n = pm.n, m = pm.m, k = pm.k, p = pm.p;
  const size_t se = size_t(e);
  ReferenceInput in;
  in.f = pm.has_drift ? Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(&pb.f[se * n], n)) : Eigen::VectorXd::Zero(n);
  in.G = Eigen::MatrixXd::Zero(n, m);
  if (pm.g_form == GForm::Diagonal) {
    for (int j = 0; j < n; ++j) in.G(j, j) = pb.G[se * n + j];
  } else {
    for (int r = 0; r < n; ++r)
      for (int j = 0; j < m; ++j) in.G(r, j) = pb.G[(se * n + r) * m + j];
  }
  in.c = Eigen::Map<const Eigen::VectorXd>(&pb.c[se * k], k);
  in.Jq = Eigen::MatrixXd(k, n);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < n; ++j) in.Jq(i, j) = pb.Jq[(se * k + i) * n + j];
  in.Jx = Eigen::MatrixXd::Zero(k, p);
  in.xdot = Eigen::VectorXd::Zero(p);
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < p; ++j) in.Jx(i, j) = pb.Jx[(se * k + i) * p + j];
  for (int j = 0; j < p; ++j) in.xdot(j) = pb.xdot[se * p + j];
  in.alpha = Eigen::Map<const Eigen::VectorXd>(&pb.alpha[se * m], m);
  return in;
}

struct History {
  int k = 0, m = 0;
  std::vector<double> c;        // (N x kHistory x k) pre-step rows, newest at slot (t % kHistory)
  std::vector<double> lambda;   // (N x kHistory)
  std::vector<uint8_t> bias;    // (N x kHistory)
  std::vector<long> round;      // (N x kHistory) round of the slot, -1 empty
  void resize(int N, int kk, int mm) {
    k = kk;
    m = mm;
    c.assign(size_t(N) * kHistory * k, 0.0);
    lambda.assign(size_t(N) * kHistory, 0.0);
    bias.assign(size_t(N) * kHistory, 0);
    round.assign(size_t(N) * kHistory, -1);
  }
};

}  // namespace

bool first_order_keep_exists(int m, int k, const double* JG, const double* c, const double* F, const double* bound,
                             double dt, const double* a_pref, double* a) {
  std::vector<double> g(size_t(k) * m), h(static_cast<size_t>(k));
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < m; ++j) g[size_t(i) * m + j] = dt * JG[size_t(i) * m + j];
    h[size_t(i)] = bound[i] - c[i] - dt * F[i];
  }
  return (safelayer_solve(m, k, g.data(), h.data(), a_pref, a) & kSafeLayerInfeasible) == 0;
}

nlohmann::json run_viability_audit(const ViabilityAuditConfig& cfg) {
  const RolloutConfig& rc = cfg.rollout;
  if (rc.policy != "random" && rc.policy != "zero" && rc.policy != "la")
    throw std::invalid_argument("viability: --policy must be random, zero or la");
  PolicyRequest req;
  req.policy = rc.policy;
  req.env = rc.env;
  req.safety = SafetyLayer::None;
  req.env_config = rc.env_config;
  PolicySource src = resolve_policy_source(req);
  auto env_owner = make_env(EnvRequest{src.env, rc.envs, SafetyLayer::None, src.env_config});
  auto* env = dynamic_cast<ControlAffineEnv*>(env_owner.get());
  if (!env) throw std::invalid_argument("viability: env '" + src.env + "' has no constraint model");
  const EnvSpec& spec = env->spec();
  const int N = rc.envs, m = spec.act_dim, k = spec.num_constraints;
  ProjectorModel pm = env->projector_model();
  if (cfg.bounds) pm.bounds = *cfg.bounds;
  pm.validate();
  ProjectorBatch pb(pm, N);
  Policy* policy = &src.bind(spec);
  env->seed(rc.seed);

  // The same per-env action streams as run_rollout.
  std::vector<Rng> rng;
  rng.reserve(N);
  for (int i = 0; i < N; ++i) rng.emplace_back(rc.seed ^ 0xA5A5A5A5ull, static_cast<uint64_t>(i) + (1ull << 40));
  std::vector<double> actions(size_t(N) * m, 0.0);

  std::unique_ptr<std::ofstream> csv;
  if (!cfg.csv.empty()) {
    csv = std::make_unique<std::ofstream>(cfg.csv);
    if (!*csv) throw std::runtime_error("viability: cannot write '" + cfg.csv + "'");
    *csv << "round,env,row,row_name,tolerance,class,c_prev,c_post,c_lin,c_nonlinear,slack,slack_rate,"
            "lambda,bias_out,b_max,t_max,a_max,saturated_joint,jg_norm,dc_correction,dc_tangent,rows_near,"
            "keep_exists,keep_lambda_max,drift_rate,escape_rate,c_prev1,c_prev2,c_prev3,lambda_prev1,bias_prev1,alpha,obs\n";
  }
  long records = 0;

  const size_t ni = spec.info_names.size();
  std::vector<int> collision_cols;
  for (size_t c = 0; c < ni; ++c)
    if (is_contact(spec.role(c))) collision_cols.push_back(int(c));
  std::vector<double> collision_sums(collision_cols.size(), 0.0);
  History hist;
  hist.resize(N, k, m);
  std::map<std::string, long> classes;
  long episodes = 0, terminations = 0, violations = 0, bias_steps = 0;
  double max_c = -INFINITY, max_nonlinear = 0.0, max_drift = 0.0;
  std::vector<double> row_max(size_t(k), -INFINITY);  // largest value each row reached
  long drift_over_escape = 0;
  const bool moving = pm.has_drift || pm.p > 0;
  const long rounds = (rc.steps + N - 1) / N;
  long done_steps = 0;
  std::vector<double> c_prev_all(size_t(N) * k);
  std::vector<double> a_qp(m), a0(m, 0.0);
  const int od = spec.obs_dim;
  std::vector<float> obs_prev(csv ? size_t(N) * od : 0);  // the pre-step observations (CSV only)
  // The reported rows before the step. An env may enforce stricter rows than
  // it reports (nav: look-ahead and sweep); the analysis then moves each
  // reported row with its layer row's Jacobian.
  std::vector<double> c_rep_prev(size_t(N) * k);
  std::vector<uint8_t> fresh(size_t(N), 1);  // 1: the env's episode starts with this step
  for (long r = 0; r < rounds; ++r) {
    const int active = static_cast<int>(std::min<long>(N, rc.steps - done_steps));
    policy->act(env->buffers().obs.data(), N, true, rng.data(), actions.data());
    std::copy(actions.begin(), actions.end(), pb.alpha.begin());
    if (csv) std::copy(env->buffers().obs.begin(), env->buffers().obs.end(), obs_prev.begin());
    std::copy(env->buffers().constraints.begin(), env->buffers().constraints.end(), c_rep_prev.begin());
    parallel_blocks(N, kEnvBlock, [&](int64_t lo, int64_t hi) {
      env->constraint_model(pb, int(lo), int(hi));
      project_range(pm, pb, int(lo), int(hi), {.store_slack = false});
    });
    if (moving) {
      // Before the step: how fast the uncontrolled part closes each row
      // (F_i = J_q,i f + J_x,i xdot) against the fastest retreat the box
      // allows (|J_G,i|_1, J_G = J_q G).
      for (int i = 0; i < active; ++i) {
        const ReferenceInput in = reference_input(pm, pb, i);
        Eigen::VectorXd F = Eigen::VectorXd::Zero(k);
        if (pm.has_drift) F += in.Jq * in.f;
        if (pm.p > 0) F += in.Jx * in.xdot;
        // A row no first-order layer can keep this step, whatever the
        // other rows: F_i > |J_G,i|_1 + s_i / dt with s_i = max(-c_i, 0).
        bool over = false;
        for (int row = 0; row < k; ++row) {
          if (!(F(row) > 0.0)) continue;
          max_drift = std::max(max_drift, F(row));
          const double room = std::max(-in.c(row), 0.0) / spec.dt;
          over = over || F(row) > (in.Jq.row(row) * in.G).cwiseAbs().sum() + room;
        }
        drift_over_escape += over;
      }
    }
    env->step(pb.a.data());
    const EnvBuffers& b = env->buffers();
    for (int i = 0; i < active; ++i) {
      episodes += b.done(i);
      terminations += b.terminated[i] != 0;
      bias_steps += (pb.status[i] & kStatusBiasOutOfBounds) != 0;
      for (size_t c = 0; c < collision_cols.size(); ++c) collision_sums[c] += b.info[size_t(i) * ni + collision_cols[c]];
      bool violated = false;
      int worst = -1;
      double worst_excess = 0.0;
      for (int row = 0; row < k; ++row) {
        const double c = b.constraints[size_t(i) * k + row];
        if (!std::isfinite(c)) continue;
        max_c = std::max(max_c, c);
        row_max[size_t(row)] = std::max(row_max[size_t(row)], c);
        const double excess = c - spec.constraint_tolerance[row];
        if (excess > 0.0 && (worst < 0 || excess > worst_excess)) {
          worst = row;
          worst_excess = excess;
        }
        violated = violated || excess > 0.0;
      }
      if (violated) {
        ++violations;
        // Everything below reads the pre-step inputs, still in pb.
        const ReferenceInput in = reference_input(pm, pb, i);
        const ReferenceOutput ref = project_reference(pm, in);
        const Eigen::MatrixXd JG = in.Jq * in.G;
        Eigen::VectorXd F = Eigen::VectorXd::Zero(k);
        if (pm.has_drift) F += in.Jq * in.f;
        if (pm.p > 0) F += in.Jx * in.xdot;
        Eigen::VectorXd a_app(m);
        for (int j = 0; j < m; ++j) a_app(j) = std::clamp(pb.a[size_t(i) * m + j], -1.0, 1.0);
        // After an autoreset the buffers still hold the last episode's rows:
        // the new episode's first step starts from the layer's rows.
        const Eigen::VectorXd c_rep =
            fresh[size_t(i)] ? in.c : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(&c_rep_prev[size_t(i) * k], k));
        const Eigen::VectorXd c_lin = c_rep + spec.dt * (JG * a_app + F);
        // Bounds on the layer's rows that keep the reported rows within tolerance.
        Eigen::VectorXd bound(k);
        for (int rr = 0; rr < k; ++rr) bound(rr) = spec.constraint_tolerance[rr] + in.c(rr) - c_rep(rr);
        const Eigen::VectorXd bvec = ref.b.head(m);
        const Eigen::VectorXd tvec = ref.N.topRows(m) * in.alpha.cwiseMax(-1.0).cwiseMin(1.0);
        // Which box component limited lambda (or left the box).
        int sat = -1;
        double best = INFINITY;
        for (int j = 0; j < m; ++j) {
          double lim = INFINITY;
          if (std::abs(bvec(j)) > 1.0) lim = -1.0;
          else if (tvec(j) > 0.0) lim = (1.0 - bvec(j)) / tvec(j);
          else if (tvec(j) < 0.0) lim = (-1.0 - bvec(j)) / tvec(j);
          if (lim < best) {
            best = lim;
            sat = j;
          }
        }
        if (best >= 1.0) sat = -1;
        // Exact first-order test: an action in the box with
        // c + dt (J_G a + F) <= tolerance on every row (QP feasibility).
        const Eigen::Matrix<double, -1, -1, Eigen::RowMajor> JGr = JG;
        const bool keep_exists =
            first_order_keep_exists(m, k, JGr.data(), in.c.data(), F.data(), bound.data(), spec.dt, a0.data(), a_qp.data());
        // Largest tangential scale whose first-order prediction keeps every row within tolerance.
        double keep_lambda = 1.0;
        for (int row = 0; row < k; ++row) {
          const double base = c_rep(row) + spec.dt * (JG.row(row).dot(bvec) + F(row)) - spec.constraint_tolerance[row];
          const double slope = spec.dt * JG.row(row).dot(tvec);
          if (base > 0.0) keep_lambda = std::min(keep_lambda, slope < 0.0 ? base / -slope : -1.0);
          else if (slope > 0.0) keep_lambda = std::min(keep_lambda, -base / slope);
        }
        const int row = worst;
        const double c_prev = c_rep(row), c_post = b.constraints[size_t(i) * k + row];
        const double tol = spec.constraint_tolerance[row];
        const bool bias = (pb.status[i] & kStatusBiasOutOfBounds) != 0;
        std::string cls;
        if (c_prev > tol) cls = "chain";
        else if (!keep_exists) cls = "not_viable";
        else if (bias) cls = "bias_out";
        else if (c_lin(row) > tol) cls = "tangent";
        else cls = "nonlinear";
        ++classes[cls];
        max_nonlinear = std::max(max_nonlinear, c_post - c_lin(row));
        int near = 0;
        for (int rr = 0; rr < k; ++rr) near += c_rep(rr) > -0.02;
        if (csv && records < cfg.max_records) {
          ++records;
          auto prev = [&](int back) {
            const size_t slot = size_t(i) * kHistory + size_t((r - back) % kHistory + kHistory) % kHistory;
            return hist.round[slot] == r - back ? hist.c[slot * k + row] : NAN;
          };
          const size_t s1 = size_t(i) * kHistory + size_t((r - 1) % kHistory + kHistory) % kHistory;
          const bool have1 = hist.round[s1] == r - 1;
          const double slack = ref.s(row);
          char line[1024];
          std::snprintf(line, sizeof line,
                        "%ld,%d,%d,%s,%g,%s,%.6g,%.6g,%.6g,%.6g,%.4g,%.4g,%.4g,%d,%.4g,%.4g,%.4g,%d,%.4g,%.4g,%.4g,%d,%d,"
                        "%.4g,%.4g,%.4g,%.6g,%.6g,%.6g,%.4g,%d,",
                        r, i, row, spec.constraint_names[row].c_str(), tol, cls.c_str(), c_prev, c_post, c_lin(row),
                        c_post - c_lin(row), slack,
                        slack_rate(pm.slack[row], slack, pm.beta[row], pm.tol[row]), pb.lambda[i], bias ? 1 : 0,
                        bvec.cwiseAbs().maxCoeff(), tvec.cwiseAbs().maxCoeff(), a_app.cwiseAbs().maxCoeff(), sat,
                        JG.row(row).norm(), spec.dt * JG.row(row).dot(bvec),
                        spec.dt * pb.lambda[i] * JG.row(row).dot(tvec), near, keep_exists ? 1 : 0, keep_lambda, F(row), JG.row(row).cwiseAbs().sum(), prev(1),
                        prev(2), prev(3), have1 ? hist.lambda[s1] : NAN, have1 ? int(hist.bias[s1]) : -1);
          *csv << line;
          // The policy's action, then the pre-step observation, ';'-separated
          // (round-trip precision): enough to replay the step (tests/test_viability.cpp).
          for (int j = 0; j < m; ++j) {
            std::snprintf(line, sizeof line, "%s%.17g", j ? ";" : "", pb.alpha[size_t(i) * m + j]);
            *csv << line;
          }
          *csv << ',';
          for (int d = 0; d < od; ++d) {
            std::snprintf(line, sizeof line, "%s%.9g", d ? ";" : "", double(obs_prev[size_t(i) * od + d]));
            *csv << line;
          }
          *csv << '\n';
        }
      }
      // History: this step's pre-step rows; an env that reset starts over.
      fresh[size_t(i)] = b.done(i);
      const size_t slot = size_t(i) * kHistory + size_t(r % kHistory);
      if (b.done(i)) {
        for (int s = 0; s < kHistory; ++s) hist.round[size_t(i) * kHistory + s] = -1;
      } else {
        std::copy_n(&c_rep_prev[size_t(i) * k], k, &hist.c[slot * k]);
        hist.lambda[slot] = pb.lambda[i];
        hist.bias[slot] = (pb.status[i] & kStatusBiasOutOfBounds) != 0;
        hist.round[slot] = r;
      }
    }
    done_steps += active;
  }
  // As run_rollout: every *collision column summed as "<name>s".
  nlohmann::json coll = nlohmann::json::object();
  coll["collisions"] = 0;
  for (size_t c = 0; c < collision_cols.size(); ++c)
    coll[spec.info_names[collision_cols[c]] + "s"] = static_cast<long>(std::llround(collision_sums[c]));
  nlohmann::json cls = nlohmann::json::object();
  for (const auto& [name, count] : classes) cls[name] = count;
  // Per row: the largest value reached and its tolerance (the env's sizing
  // rule for tolerances reads these, docs/envs_arm.md).
  nlohmann::json rows = nlohmann::json::object();
  for (int row = 0; row < k; ++row)
    if (std::isfinite(row_max[size_t(row)]))
      rows[spec.constraint_names[size_t(row)]] = {row_max[size_t(row)], spec.constraint_tolerance[size_t(row)]};
  nlohmann::json out = {{"env", src.env},
          {"policy", rc.policy},
          {"bounds", bound_rule_name(pm.bounds)},
          {"envs", N},
          {"seed", rc.seed},
          {"steps", done_steps},
          {"episodes", episodes},
          {"terminations", terminations},
          {"violations", violations},
          {"bias_out_steps", bias_steps},
          {"max_constraint", k ? nlohmann::json(max_c) : nlohmann::json(nullptr)},
          {"max_nonlinear", max_nonlinear},
          {"classes", cls},
          {"row_max", rows},
          {"max_drift_rate", max_drift},
          {"drift_over_escape_steps", drift_over_escape}};
  out.update(coll);
  return out;
}

}  // namespace atacom
