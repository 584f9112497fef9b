// The one env snapshot format (src/core/snapshot.hpp): the container refuses
// truncated, foreign, mis-tagged and corrupted input with a message naming
// the problem, and every env (table, hri, nav, pendulum) restores bitwise.
#include <catch2/catch.hpp>

#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "atacom/env.hpp"
#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "src/core/snapshot.hpp"

using namespace atacom;

namespace {

constexpr uint32_t kTagTest = snapshot_tag("TEST");
constexpr uint32_t kTagA = snapshot_tag("AAAA");
constexpr uint32_t kTagB = snapshot_tag("BBBB");

std::string snapshot_sample() {
  SnapshotWriter w(kTagTest, "test");
  bin::write_vec(w.section(kTagA), std::vector<double>{1.0, 2.0, 3.0});
  bin::write_pod<int32_t>(w.section(kTagB), 7);
  std::ostringstream out;
  w.finish(out);
  return out.str();
}

// Reads snapshot_sample()'s layout back.
void read_snapshot_sample(const std::string& bytes, uint32_t env = kTagTest) {
  std::istringstream in(bytes);
  SnapshotReader r(in, env, "test");
  std::vector<double> v;
  bin::read_vec(r.section(kTagA, "a"), v, "a", 3);
  REQUIRE(v == std::vector<double>{1.0, 2.0, 3.0});
  REQUIRE(bin::read_pod<int32_t>(r.section(kTagB, "b"), "b") == 7);
  r.finish();
}

std::string snapshot(const BatchEnv& env) {
  std::ostringstream out;
  env.save_state(out);
  return out.str();
}

void drive(BatchEnv& env, Rng& rng, int steps) {
  std::vector<double> a(size_t(env.num_envs()) * size_t(env.spec().act_dim));
  for (int s = 0; s < steps; ++s) {
    for (double& x : a) x = rng.uniform(-1.0, 1.0);
    env.step(a.data());
  }
}

}  // namespace

TEST_CASE("snapshot format: round trip, and bad input refused by name", "[snapshot]") {
  const std::string good = snapshot_sample();
  read_snapshot_sample(good);
  // Layout: u32 magic, u32 env, u32 version, u64 length, sections, u64 checksum.
  REQUIRE(good.size() == 20 + (12 + 8 + 24) + (12 + 4) + 8);

  for (size_t cut : {size_t(0), size_t(3), size_t(12), size_t(19), size_t(20), good.size() / 2, good.size() - 1}) {
    INFO("cut at " << cut);
    REQUIRE_THROWS_WITH(read_snapshot_sample(good.substr(0, cut)), Catch::Contains("test snapshot: truncated"));
  }
  REQUIRE_THROWS_WITH(read_snapshot_sample(good, snapshot_tag("ELSE")), Catch::Contains("holds env 'TEST', this env is 'ELSE'"));
  std::string magic = good;
  magic[0] = 'X';
  REQUIRE_THROWS_WITH(read_snapshot_sample(magic), Catch::Contains("not an env snapshot"));
  std::string version = good;
  version[8] = 9;
  REQUIRE_THROWS_WITH(read_snapshot_sample(version), Catch::Contains("format version 9"));
  for (size_t at : {size_t(20), size_t(30), good.size() - 12, good.size() - 1}) {  // section header, data, checksum
    INFO("flipped byte " << at);
    std::string flipped = good;
    flipped[at] ^= 0x04;
    REQUIRE_THROWS_WITH(read_snapshot_sample(flipped), Catch::Contains("checksum mismatch"));
  }

  // Intact snapshots (valid checksums) whose sections do not match the reader.
  {
    std::istringstream in(good);
    SnapshotReader r(in, kTagTest, "test");
    REQUIRE_THROWS_WITH(r.section(kTagB, "b"), Catch::Contains("expected section b ('BBBB'), found 'AAAA'"));
  }
  {
    std::istringstream in(good);
    SnapshotReader r(in, kTagTest, "test");
    bin::read_pod<double>(r.section(kTagA, "a"), "a");  // reads 8 of the section's 32 bytes
    REQUIRE_THROWS_WITH(r.section(kTagB, "b"), Catch::Contains("section a has 32 bytes, this build reads 8"));
  }
  {
    std::istringstream in(good);
    SnapshotReader r(in, kTagTest, "test");
    std::vector<double> v;
    bin::read_vec(r.section(kTagA, "a"), v, "a", 3);
    REQUIRE_THROWS_WITH(r.finish(), Catch::Contains("holds sections this build does not read"));
  }
  {
    std::istringstream in(good);
    SnapshotReader r(in, kTagTest, "test");
    std::vector<double> v;
    bin::read_vec(r.section(kTagA, "a"), v, "a", 3);
    REQUIRE(bin::read_pod<int32_t>(r.section(kTagB, "b"), "b") == 7);
    REQUIRE_THROWS_WITH(r.section(kTagA, "c"), Catch::Contains("section c is missing"));
  }
  // A length the input does not back ends in "truncated", not a huge allocation.
  std::string huge = good;
  const uint64_t n = uint64_t{1} << 40;
  std::memcpy(&huge[12], &n, 8);
  REQUIRE_THROWS_WITH(read_snapshot_sample(huge), Catch::Contains("truncated"));
}

TEST_CASE("snapshot format: every env restores bitwise and refuses others' snapshots", "[snapshot]") {
  struct Case {
    const char* name;
    int N;
  };
  std::vector<std::string> saved;
  for (const Case c : {Case{"table", 19}, Case{"hri", 11}, Case{"nav", 13}, Case{"pendulum", 7}}) {
    INFO(c.name);
    auto env = make_env({.name = c.name, .num_envs = c.N});
    env->seed(5);
    Rng rng(6, 0);
    drive(*env, rng, 40);
    const std::string at = snapshot(*env);
    saved.push_back(at);
    const Rng rng_at = rng;
    drive(*env, rng, 60);
    const std::string after = snapshot(*env);

    // Into a fresh env of another seed: the same bytes back, and the same run on.
    auto other = make_env({.name = c.name, .num_envs = c.N});
    other->seed(99);
    std::istringstream in(at);
    const float* obs_storage = other->buffers().obs.data();  // views (numpy, the trainer) hold these pointers
    const double* c_storage = other->buffers().constraints.data();
    other->load_state(in);
    CHECK(other->buffers().obs.data() == obs_storage);
    CHECK(other->buffers().constraints.data() == c_storage);
    REQUIRE(snapshot(*other) == at);
    rng = rng_at;
    drive(*other, rng, 60);
    REQUIRE(snapshot(*other) == after);
    REQUIRE(other->buffers().obs == env->buffers().obs);

    // Refused, and the env keeps its state: truncated, corrupted, another batch size.
    const std::string before = snapshot(*other);
    std::istringstream cut(at.substr(0, at.size() - 9));
    REQUIRE_THROWS_WITH(other->load_state(cut), Catch::Contains("snapshot: truncated"));
    std::string flipped = at;
    flipped[at.size() / 2] ^= 0x01;
    std::istringstream bad(flipped);
    REQUIRE_THROWS_WITH(other->load_state(bad), Catch::Contains("checksum mismatch"));
    auto smaller = make_env({.name = c.name, .num_envs = c.N - 1});
    std::istringstream wrong_n(at);
    REQUIRE_THROWS_WITH(smaller->load_state(wrong_n),
                        Catch::Contains("holds " + std::to_string(c.N) + " envs, this env has " + std::to_string(c.N - 1)));
    REQUIRE(snapshot(*other) == before);
  }
  // Another family's snapshot (table's into nav) and another arm task's
  // (table's into shelf, same env tag, other config) are refused by name.
  auto nav = make_env({.name = "nav", .num_envs = 19});
  std::istringstream t1(saved[0]);
  REQUIRE_THROWS_WITH(nav->load_state(t1), Catch::Contains("holds env 'ARM ', this env is 'NAV '"));
  auto shelf = make_env({.name = "shelf", .num_envs = 19});
  std::istringstream t2(saved[0]);
  REQUIRE_THROWS_WITH(shelf->load_state(t2), Catch::Contains("different env config"));
}
