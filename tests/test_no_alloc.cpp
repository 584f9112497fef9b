// The batched kernels must not allocate per call once warmed up. Counted by
// interposing the C allocator for this test binary (forwarding to glibc);
// skipped under AddressSanitizer, which owns the allocator there.
#include <catch2/catch.hpp>

#include <atomic>
#include <cerrno>
#include <cstddef>

#include "envs/arm/arm_env.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_rows.hpp"
#include "atacom/projector.hpp"
#include "kernels/redsdf_batch.hpp"
#include "atacom/rng.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "train/ppo_learner.hpp"
#include "build_kind.hpp"

#if ATACOM_TEST_SANITIZED
#define ATACOM_COUNT_ALLOCS 0
#else
#define ATACOM_COUNT_ALLOCS 1
#endif

#if ATACOM_COUNT_ALLOCS
namespace {
std::atomic<long> g_allocs{0};
}
extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
void __libc_free(void*);
void* malloc(size_t n) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(n);
}
void* calloc(size_t a, size_t b) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_calloc(a, b);
}
void* realloc(void* p, size_t n) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_realloc(p, n);
}
void free(void* p) { __libc_free(p); }
void* memalign(size_t al, size_t n) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(al, n);
}
void* aligned_alloc(size_t al, size_t n) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  return __libc_memalign(al, n);
}
int posix_memalign(void** out, size_t al, size_t n) {
  g_allocs.fetch_add(1, std::memory_order_relaxed);
  *out = __libc_memalign(al, n);
  return *out ? 0 : ENOMEM;
}
}
#endif

using namespace atacom;

TEST_CASE("no allocation: projector kernel paths after warm-up", "[alloc]") {
#if !ATACOM_COUNT_ALLOCS
  SUCCEED("allocation counting disabled under AddressSanitizer");
#else
  for (int variant = 0; variant < 4; ++variant) {
    ProjectorModel mod = default_projector_model(7, 7, 34, 3);
    if (variant == 1) mod.g_form = GForm::Diagonal;
    if (variant == 2) mod.basis = BasisType::Smooth;
    if (variant == 3) mod.equality[5] = 1;
    ProjectorBatch B(mod, 100);
    Rng rng(1, variant);
    for (auto& v : B.f) v = rng.normal();
    for (auto& v : B.G) v = rng.uniform(0.5, 1.5);
    for (auto& v : B.c) v = rng.uniform(-1, 0.1);
    for (auto& v : B.Jq) v = rng.normal();
    for (auto& v : B.Jx) v = rng.normal();
    for (auto& v : B.xdot) v = rng.normal();
    for (auto& v : B.alpha) v = rng.uniform(-1, 1);
    project_range(mod, B, 0, 100, {.store_basis = true});  // warm-up: scratch sized here
    const long before = g_allocs.load();
    for (int rep = 0; rep < 3; ++rep) project_range(mod, B, 0, 100, {.store_basis = true});
    const long allocs = g_allocs.load() - before;  // read before INFO, which allocates itself
    INFO("variant " << variant);
    CHECK(allocs == 0);
  }
#endif
}

TEST_CASE("no allocation: arm env step, resets and constraint model (table, shelf, hri)", "[alloc]") {
#if !ATACOM_COUNT_ALLOCS
  SUCCEED("allocation counting disabled under AddressSanitizer");
#else
  for (ArmTask task : {ArmTask::Table, ArmTask::Shelf, ArmTask::Hri}) {
    const int N = 200;  // one parallel block: runs on this thread
    ArmEnv env(default_arm_env_config(task), N);
    ProjectorBatch pb(env.projector_model(), N);
    Rng rng(2, 0);
    std::vector<double> a(static_cast<size_t>(N) * kArmJoints);
    for (double& x : a) x = rng.uniform(-1, 1);
    env.step(a.data());
    const long before = g_allocs.load();
    int episodes = 0;
    for (int rep = 0; rep < 60; ++rep) {
      for (double& x : a) x = rng.uniform(-1, 1);
      env.step(a.data());  // random actions: many episodes end and reset here
      env.constraint_model(pb, 0, N);
      for (int e = 0; e < N; ++e) episodes += env.buffers().done(e);
    }
    const long allocs = g_allocs.load() - before;
    INFO(arm_task_name(task) << " episodes " << episodes);
    CHECK(episodes > 10);
    CHECK(allocs == 0);
  }
#endif
}

TEST_CASE("no allocation: human motion, capsules, rows and contacts", "[alloc]") {
#if !ATACOM_COUNT_ALLOCS
  SUCCEED("allocation counting disabled under AddressSanitizer");
#else
  const HumanModel m = load_human_model();
  const HumanMotionLibrary lib = load_default_human_motion();
  const int N = 37, P = 9, nq = 7, items = 4;
  HumanBatch B(N);
  const HumanRowsConst rows = make_human_rows(std::vector<double>(P, 0.1), nq, 0.02);
  std::vector<double> t(N), poi(static_cast<size_t>(N) * P * 3, 1.0), J(static_cast<size_t>(N) * P * 3 * nq, 0.5);
  std::vector<double> c(static_cast<size_t>(N) * P), Jq(static_cast<size_t>(N) * P * nq), dcdt(c), dex(c);
  std::vector<double> it(static_cast<size_t>(N) * items * 6, 0.9), radii(items, 0.05), dmin(N);
  std::vector<uint8_t> contact(N);
  for (int e = 0; e < N; ++e) t[static_cast<size_t>(e)] = 100.0 + 391.7 * e;
  const HumanReplayConfig replay;
  const long before = g_allocs.load();
  for (int rep = 0; rep < 3; ++rep) {
    human_motion_range(lib, replay, 1.0 / 30.0, t.data(), B, 0, N);
    human_capsules_range(m.fk, B, 0, N);
    human_rows_range(rows, m.fk, B, poi.data(), J.data(), c.data(), Jq.data(), dcdt.data(), dex.data(), 0, N);
    human_contact_range(B, m.fk, it.data(), radii.data(), items, contact.data(), dmin.data(), 0, N);
  }
  const long allocs = g_allocs.load() - before;
  CHECK(allocs == 0);
#endif
}

TEST_CASE("no allocation: learned SDF batched inference after construction", "[alloc]") {
#if !ATACOM_COUNT_ALLOCS
  SUCCEED("allocation counting disabled under AddressSanitizer");
#else
  RedsdfArch a;
  a.pose_dim = 2;
  a.hidden = {64, 64, 64, 64};
  RedsdfModel m(a);
  init_redsdf(m, 1);
  RedsdfBatch batch(m);
  const int n = 4096 + 17;
  std::vector<float> p(3 * size_t(n), 0.3f), pose(2 * size_t(n), 0.1f), d(static_cast<size_t>(n)), g(3 * static_cast<size_t>(n));
  batch.evaluate(p.data(), pose.data(), false, n, d.data(), g.data());  // warm-up: TBB worker start
  const long before = g_allocs.load();
  for (int rep = 0; rep < 3; ++rep) batch.evaluate(p.data(), pose.data(), false, n, d.data(), g.data());
  const long allocs = g_allocs.load() - before;
  CHECK(allocs == 0);
#endif
}

// PPO's side of a training step: the learner's sampled act over N envs and
// observe(), whose last call of a rollout runs the update (value pass, GAE,
// minibatch epochs with both tapes and Adam). Two rollouts warm up the
// tapes' arenas (the minibatches come in two sizes). The env step between
// them is not counted: the projector's per-thread scratch is sized the first
// time a thread runs it, which a TBB worker may first do after any warm-up
// (2 allocations, seen in about 1 run of 5 on a loaded host).
TEST_CASE("no allocation: PPO act, observe and update after warm-up", "[alloc]") {
#if !ATACOM_COUNT_ALLOCS
  SUCCEED("allocation counting disabled under AddressSanitizer");
#else
  const int N = 300;
  PpoConfig c = default_ppo_config();
  c.rollout_steps = 4;
  c.epochs = 2;
  c.minibatch_size = 170;  // 1200 rows: 7 minibatches of 171 and 172 rows
  c.value_clip_range = 0.5;
  for (const auto mode : {LogStdMode::StateIndependent, LogStdMode::StateDependent}) {
    c.log_std = mode;
    auto env = make_env(EnvRequest{"table", N, SafetyLayer::Atacom});
    env->seed(1);
    const LearnerContext ctx{&env->spec(), N, 1, &env->buffers()};
    PpoLearner learner(ctx, c);
    std::vector<Rng> rngs;
    for (int i = 0; i < N; ++i) rngs.emplace_back(1, uint64_t(i));
    std::vector<float> obs = env->buffers().obs;
    std::vector<double> act(size_t(N) * 7);
    long allocs = 0;  // in act() and observe()
    auto step = [&]() {
      long a0 = g_allocs.load();
      learner.policy().act(obs.data(), N, false, rngs.data(), act.data());
      allocs += g_allocs.load() - a0;
      env->step(act.data());
      a0 = g_allocs.load();
      learner.observe(obs.data(), act.data(), env->buffers());
      allocs += g_allocs.load() - a0;
      std::copy(env->buffers().obs.begin(), env->buffers().obs.end(), obs.begin());
    };
    for (int k = 0; k < 2 * c.rollout_steps; ++k) step();
    allocs = 0;
    for (int k = 0; k < 2 * c.rollout_steps; ++k) step();
    REQUIRE(learner.updates() == 4 * 2 * 7);
    CHECK(allocs == 0);
  }
#endif
}
