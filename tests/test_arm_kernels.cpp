// The arm env's kernels over an env range (envs/arm/arm_kernels.hpp): a step
// of a range that is not block- or lane-aligned touches only that range, and
// its cached rows, J_q and (for the moving human) J_x equal the scalar
// per-env reference; splitting a step into such ranges changes nothing.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "atacom/projector.hpp"
#include "envs/arm/arm_env.hpp"

using namespace atacom;

namespace {

std::vector<double> actions(Rng& rng, int N) {
  std::vector<double> a(static_cast<size_t>(N) * kArmJoints);
  for (double& x : a) x = rng.uniform(-1.0, 1.0);
  return a;
}

HumanFkResult human_of(const ArmModel& m, const ArmBatch& b, int e) {
  const HumanBatch& h = b.human.body;
  return human_fk_reference(*m.human, &h.pose[size_t(e) * kHumanPoseDim], &h.pose_rate[size_t(e) * kHumanPoseDim]);
}

// Env e's slice of every per-env array that step writes.
std::vector<double> env_state(const ArmModel& m, const ArmBatch& b, const EnvBuffers& out, int e) {
  std::vector<double> v;
  auto add = [&](const auto& a, size_t per) {
    for (size_t i = 0; i < per; ++i) v.push_back(double(a[size_t(e) * per + i]));
  };
  add(b.q, kArmJoints);
  add(b.goal, 3);
  add(b.t, 1);
  add(b.ret, 1);
  add(b.c, size_t(m.k));
  add(b.grasp, 3);
  add(out.obs, size_t(m.obs_dim));
  add(out.reward, 1);
  if (m.hri()) {
    add(b.human.t, 1);
    add(b.human.Jx, kArmPoi);
  }
  const double* J = b.J.data() + (size_t(e) / 8) * 8 * size_t(m.dyn) * kArmJoints + size_t(e) % 8;
  for (int r = 0; r < m.dyn * kArmJoints; ++r) v.push_back(J[r * 8]);
  return v;
}

}  // namespace

TEST_CASE("arm kernels: a step of an unaligned range equals the scalar reference and touches nothing else",
          "[arm_kernels]") {
  for (ArmTask task : {ArmTask::Table, ArmTask::Hri}) {
    INFO(arm_task_name(task));
    const int N = 37, begin = 5, end = 27;  // neither a multiple of 8 lanes nor of the 256-env block
    ArmEnvConfig cfg = default_arm_env_config(task);
    // HRI: the analytic fields, which the scalar reference evaluates (the learned human has its own tests).
    if (task == ArmTask::Hri) cfg.sdf = {{"human", "analytic"}, {"table", "analytic"}, {"tiago", "analytic"}};
    ArmEnv env(cfg, N);
    env.seed(11);
    Rng rng(12, 0);
    for (int s = 0; s < 5; ++s) env.step(actions(rng, N).data());
    const ArmModel& m = *env.arm_model();
    ArmBatch b = env.batch();
    EnvBuffers out = env.buffers();
    const ArmBatch before = b;
    const EnvBuffers out_before = out;
    const std::vector<double> a = actions(rng, N);
    arm_step_range(m, b, out, a.data(), begin, end, nullptr);
    for (int e = 0; e < N; ++e) {
      if (e >= begin && e < end) continue;
      CHECK(env_state(m, b, out, e) == env_state(m, before, out_before, e));
    }
    ProjectorBatch pb(arm_projector_model(m), N);
    arm_constraint_model_range(m, b, pb, 3, 30);  // unaligned too
    const int K = m.k, p = m.rows.moving_groups();
    int checked = 0;
    for (int e = begin; e < end; ++e) {
      CHECK(b.t[size_t(e)] != before.t[size_t(e)]);  // stepped (or reset to 0 by an autoreset)
      HumanFkResult human;
      if (m.hri()) human = human_of(m, b, e);
      const ArmEval ev = evaluate_reference(m, &b.q[size_t(e) * kArmJoints], m.hri() ? &human : nullptr);
      for (int r = 0; r < K; ++r) {
        CHECK(std::abs(b.c[size_t(e) * K + r] - ev.c(r)) < 1e-9);
        CHECK(std::abs(pb.c[size_t(e) * K + r] - ev.c(r)) < 1e-9);
        for (int j = 0; j < kArmJoints; ++j)
          CHECK(std::abs(pb.Jq[(size_t(e) * K + r) * kArmJoints + j] - ev.J(r, j)) < 1e-9);
        if (p > 0) CHECK(std::abs(pb.Jx[size_t(e) * K + r] - ev.dcdt(r)) < 1e-5);  // reference: central differences
      }
      if (p > 0) CHECK(pb.xdot[size_t(e)] == 1.0);
      for (int r = 0; r < 3; ++r) CHECK(std::abs(b.grasp[size_t(e) * 3 + r] - ev.grasp_p(r)) < 1e-9);
      ++checked;
    }
    CHECK(checked == end - begin);

    // The same step split into unaligned ranges gives the whole-range result.
    ArmBatch whole = before, split = before;
    EnvBuffers out_whole = out_before, out_split = out_before;
    arm_step_range(m, whole, out_whole, a.data(), 0, N, nullptr);
    for (auto [lo, hi] : {std::pair{0, 5}, {5, 27}, {27, 30}, {30, N}})
      arm_step_range(m, split, out_split, a.data(), lo, hi, nullptr);
    for (int e = 0; e < N; ++e) {
      const std::vector<double> x = env_state(m, whole, out_whole, e), y = env_state(m, split, out_split, e);
      REQUIRE(x.size() == y.size());
      for (size_t i = 0; i < x.size(); ++i) CHECK(std::abs(x[i] - y[i]) <= 1e-12 * (1.0 + std::abs(x[i])));
    }
  }
}

TEST_CASE("arm kernels: the human is a moving row group, the static groups are not", "[arm_kernels]") {
  const ArmRowLayout table = ArmRowLayout::compose(false), hri = ArmRowLayout::compose(true),
                     upright = ArmRowLayout::compose(true, true);
  CHECK(table.k == kArmRows);
  CHECK(table.moving_groups() == 0);
  CHECK(hri.k == kArmRows + kArmPoi);
  CHECK(!hri.has(ArmRowKind::Upright));
  CHECK(upright.k == kArmMaxRows);
  CHECK(upright.has(ArmRowKind::Upright));
  for (const ArmRowLayout* l : {&hri, &upright}) {
    CHECK(l->moving_groups() == 1);
    for (const ArmRowSpan& g : l->groups) {
      CHECK(g.moving == (g.kind == ArmRowKind::Human));
      CHECK(g.state == (g.moving ? 0 : -1));
    }
  }
  // Two envs built from one model share it (no second goal library or field).
  auto model = make_arm_model(default_arm_env_config(ArmTask::Table));
  ArmEnv a(model, 3), b(model, 5);
  CHECK(a.arm_model().get() == b.arm_model().get());
  CHECK(a.projector_model().p == 0);
}
