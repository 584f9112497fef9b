// Throughput of the two safety layers on the same inputs: SafeLayer's QP
// correction and ATACOM's projection, corrections (projections) per second.
//
// Shapes k = 34, m = 7 and k = 5, m = 2 at N = 16384, 1 and 2 threads.
// Inputs: "random" (generic systems as in bench_projector: dense G, drift,
// rows from deep inside to violated, alpha ~ U[-1, 1]) and the real envs'
// constraint models ("table": k = 34, m = 7, diagonal G; "nav": k = 5,
// m = 2, dense G with Fetch's state) at states reached by 40 random-action
// steps through SafeLayer, with fresh alpha ~ U[-1, 1]. The projector runs
// as the envs call it (no slack outputs). SafeLayer lines also give the
// share of envs whose a_pi was kept, corrected in closed form, solved as a
// QP, or infeasible, and the mean iteration count. The "cbf" lines run the
// same kernel on the CBF layer's model (src/safety/cbf_env.hpp, gamma 10:
// SafeLayer's rows with dt = 1/gamma), with the same shares.
//
// Usage: bench_safety_layers [--quick] [--only random|table|nav]
#include <cstdio>
#include <initializer_list>
#include <cstring>
#include <string>
#include <vector>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "atacom/safelayer.hpp"
#include "bench_common.hpp"
#include "src/safety/cbf_env.hpp"
#include "src/safety/safe_layer_env.hpp"

using namespace atacom;

namespace {

constexpr int kN = 16384;

struct Case {
  std::string inputs;
  ProjectorModel pm;
  SafeLayerModel sm;
  ProjectorBatch pb;
};

Case random_case(int n, int m, int k, uint64_t seed) {
  Case c{"random", default_projector_model(n, m, k, 0), {}, {}};
  c.sm = safelayer_model(c.pm, 1.0 / 30.0);
  c.pb.resize(c.pm, kN);
  Rng rng(seed, 0);
  for (auto& v : c.pb.f) v = rng.normal();
  for (auto& v : c.pb.G) v = rng.normal();
  for (auto& v : c.pb.c) v = rng.uniform(-1.0, 0.05);
  for (auto& v : c.pb.Jq) v = rng.normal();
  for (auto& v : c.pb.alpha) v = rng.uniform(-1.0, 1.0);
  return c;
}

Case env_case(const std::string& name, uint64_t seed) {
  auto env = make_env({.name = name, .num_envs = kN, .safety = SafetyLayer::SafeLayer});
  auto& sl = dynamic_cast<SafeLayerEnv&>(*env);
  const int m = env->spec().act_dim;
  Rng rng(seed, 1);
  std::vector<double> act(size_t(kN) * m);
  env->seed(seed);
  for (int t = 0; t < 40; ++t) {
    for (auto& v : act) v = rng.uniform(-1.0, 1.0);
    env->step(act.data());
  }
  Case c{name, sl.inner().projector_model(), sl.model(), {}};
  c.pb.resize(c.pm, kN);
  sl.inner().constraint_model(c.pb, 0, kN);
  for (auto& v : c.pb.alpha) v = rng.uniform(-1.0, 1.0);
  return c;
}

void run(Case& c, bool quick) {
  SafeLayerBatch out(c.sm, kN);
  ProjectorBatch pb = c.pb;  // the projector writes its outputs into its own copy
  const char* gname = c.pm.g_form == GForm::Diagonal ? "diagonal" : "dense";
  const SafeLayerModel cbf = cbf_model(c.pm, kCbfDefaultGamma);
  for (int threads : {1, 2}) {
    set_num_threads(threads);
    for (const SafeLayerModel* model : std::initializer_list<const SafeLayerModel*>{&c.sm, &cbf}) {
      const double ts = bench::best_seconds_per_call([&] { safelayer_batch(*model, c.pb, out); }, quick ? 3 : 5, 0.1);
      long kept = 0, closed = 0, qp = 0, infeasible = 0, iters = 0;
      for (int e = 0; e < kN; ++e) {
        kept += out.iterations[e] == 0;
        closed += out.iterations[e] == 1;
        qp += out.iterations[e] > 1;
        infeasible += (out.status[e] & kSafeLayerInfeasible) != 0;
        iters += out.iterations[e];
      }
      bench::emit({{"bench", model == &cbf ? "cbf" : "safelayer"}, {"N", kN}, {"k", c.sm.k}, {"m", c.sm.m},
                   {"n", c.sm.n}, {"threads", threads}, {"inputs", c.inputs}, {"G", gname}, {"per_s", kN / ts},
                   {"kept_share", double(kept) / kN}, {"closed_form_share", double(closed) / kN},
                   {"qp_share", double(qp) / kN}, {"infeasible_share", double(infeasible) / kN},
                   {"mean_iterations", double(iters) / kN}});
    }
    const double tp = bench::best_seconds_per_call([&] { project_batch(c.pm, pb, {.store_slack = false}); },
                                                   quick ? 3 : 5, 0.1);
    bench::emit({{"bench", "projector"}, {"N", kN}, {"k", c.pm.k}, {"m", c.pm.m}, {"n", c.pm.n}, {"threads", threads},
                 {"inputs", c.inputs}, {"G", gname}, {"slack_out", false}, {"per_s", kN / tp}});
  }
  set_num_threads(0);
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string only;  // one input family, or all
  CLI::App app{"bench_safety_layers: ATACOM, SafeLayer and the other layers per env and second"};
  app.add_flag("--quick", quick, "shorter timing rounds");
  app.add_option("--only", only, "one input family")->check(CLI::IsMember({"random", "table", "nav"}));
  if (int code = 0; !bench::parse_args(app, argc, argv, code)) return code;
  auto wanted = [&](const char* inputs) { return only.empty() || only == inputs; };
  if (wanted("random")) {
    Case c = random_case(7, 7, 34, 1);
    run(c, quick);
    Case c2 = random_case(3, 2, 5, 2);
    run(c2, quick);
  }
  for (const char* env : {"table", "nav"}) {
    if (!wanted(env)) continue;
    Case c = env_case(env, 3);
    run(c, quick);
  }
  return 0;
}
