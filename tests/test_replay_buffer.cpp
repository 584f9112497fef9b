#include <catch2/catch.hpp>

#include <sstream>
#include <vector>

#include "train/replay_buffer.hpp"

using atacom::ReplayBatch;
using atacom::ReplayBuffer;
using atacom::Rng;

namespace {
// Adds n rows whose every field encodes the row number k.
void add_rows(ReplayBuffer& rb, int first, int n) {
  for (int k = first; k < first + n; ++k) {
    const float obs[2] = {float(k), float(-k)}, next[2] = {float(k) + 0.5f, 0.0f}, r = float(k) * 10, c = 1.0f;
    const double act[1] = {double(k) / 1000.0};
    const uint8_t term = k % 2, trunc = k % 3 == 0;
    rb.add(1, obs, act, &r, &c, next, &term, &trunc);
  }
}
}  // namespace

TEST_CASE("replay: ring overwrites the oldest rows", "[replay]") {
  ReplayBuffer rb(5, 2, 1);
  add_rows(rb, 0, 3);
  REQUIRE(rb.size() == 3);
  add_rows(rb, 3, 4);  // rows 0 and 1 overwritten
  REQUIRE(rb.size() == 5);
  ReplayBatch b;
  b.resize(200, 2, 1);
  Rng rng(1, 0);
  rb.sample(rng, b);
  std::vector<int> seen(7, 0);
  for (int i = 0; i < b.B; ++i) {
    const int k = int(b.obs[size_t(i) * 2]);
    REQUIRE(k >= 2);
    REQUIRE(k <= 6);
    seen[size_t(k)] = 1;
    // every field of the row belongs to the same transition
    REQUIRE(b.obs[size_t(i) * 2 + 1] == float(-k));
    REQUIRE(b.next_obs[size_t(i) * 2] == float(k) + 0.5f);
    REQUIRE(b.action[size_t(i)] == float(double(k) / 1000.0));
    REQUIRE(b.reward[size_t(i)] == float(k) * 10);
    REQUIRE(b.terminated[size_t(i)] == float(k % 2));
    REQUIRE(b.truncated[size_t(i)] == float(k % 3 == 0));
  }
  for (int k = 2; k <= 6; ++k) REQUIRE(seen[size_t(k)] == 1);
}

TEST_CASE("replay: seeded sampling and snapshot round trip", "[replay]") {
  ReplayBuffer rb(100, 2, 1);
  add_rows(rb, 0, 130);
  ReplayBatch a, b;
  a.resize(16, 2, 1);
  b.resize(16, 2, 1);
  Rng r1(4, 4), r2(4, 4);
  rb.sample(r1, a);
  rb.sample(r2, b);
  REQUIRE(a.obs == b.obs);
  std::stringstream s;
  rb.save(s);
  ReplayBuffer copy(100, 2, 1);
  copy.load(s);
  REQUIRE(copy.size() == 100);
  add_rows(rb, 130, 7);
  add_rows(copy, 130, 7);
  rb.sample(r1, a);
  copy.sample(r2, b);
  REQUIRE(a.obs == b.obs);
  REQUIRE(a.reward == b.reward);
  ReplayBuffer other(50, 2, 1);
  s.seekg(0);
  REQUIRE_THROWS_WITH(other.load(s), Catch::Contains("capacity"));
  std::stringstream cut(s.str().substr(0, s.str().size() / 2));
  ReplayBuffer c2(100, 2, 1);
  REQUIRE_THROWS_WITH(c2.load(cut), Catch::Contains("truncated"));
}

TEST_CASE("replay: bad use is a clear error", "[replay]") {
  REQUIRE_THROWS_AS(ReplayBuffer(0, 2, 1), std::invalid_argument);
  ReplayBuffer rb(4, 2, 1);
  ReplayBatch b;
  b.resize(2, 2, 1);
  Rng r(0, 0);
  REQUIRE_THROWS_WITH(rb.sample(r, b), Catch::Contains("empty"));
}
