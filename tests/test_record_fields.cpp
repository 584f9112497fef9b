// One field list per record (src/core/record_fields.hpp, config_fields.hpp):
// a field added to a list reaches every consumer (count, snapshot writer and
// reader, value copy), every EnvBuffers field goes through the snapshot and
// the copy, and nav's config JSON is written and read from its one list.
#include <catch2/catch.hpp>

#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "atacom/env.hpp"
#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "envs/nav/nav_env.hpp"
#include "src/core/env_buffer_fields.hpp"
#include "src/core/record_fields.hpp"
#include "src/core/snapshot.hpp"

using namespace atacom;

namespace {

struct Demo {
  int N = 0;
  uint64_t seed = 0;
  std::vector<double> x;
  std::vector<int32_t> t;
  std::vector<Rng> rng;
  std::vector<float> added;  // the field a later build adds to the list
};

struct DemoFields {
  using Record = Demo;
  template <class V>
  static constexpr void each(V&& v) {
    v("seed", &Demo::seed);
    v("x", &Demo::x);
    v("t", [](auto& d) -> auto& { return d.t; });
    v("rng", &Demo::rng);
  }
};

// The same list with one field more, as a later build writes it.
struct DemoFieldsPlus {
  using Record = Demo;
  template <class V>
  static constexpr void each(V&& v) {
    DemoFields::each(v);
    v("added", &Demo::added, kFieldAppended);
  }
};

static_assert(field_count<DemoFields>() == 4 && field_count<DemoFieldsPlus>() == 5);
static_assert(field_count<EnvBufferFields>() == 11);

Demo demo(uint64_t seed) {
  Demo d;
  d.N = 3;
  d.seed = seed;
  Rng r(seed, 0);
  for (int i = 0; i < 3; ++i) {
    d.x.push_back(r.uniform(-1.0, 1.0));
    d.t.push_back(int32_t(seed) + i);
    d.rng.emplace_back(seed, uint64_t(i));
    d.added.push_back(float(seed) + 0.5f * float(i));
  }
  d.rng[1].normal();  // a stream with a spare normal
  return d;
}

template <class F>
std::string bytes_of(const Demo& d) {
  std::ostringstream out;
  write_fields<F>(out, d);
  return out.str();
}

bool same(const Demo& a, const Demo& b) {
  bool rng = a.rng.size() == b.rng.size();
  for (size_t i = 0; rng && i < a.rng.size(); ++i) {
    const Rng::State s = a.rng[i].state(), o = b.rng[i].state();
    rng = std::equal(std::begin(s.s), std::end(s.s), std::begin(o.s)) && s.has_spare == o.has_spare &&
          (!s.has_spare || s.spare == o.spare);
  }
  return a.seed == b.seed && a.x == b.x && a.t == b.t && rng && a.added == b.added;
}

}  // namespace

TEST_CASE("record fields: a field added to the list reaches every consumer", "[snapshot][record_fields]") {
  const Demo a = demo(7);
  // The writer: the added field's bytes (count + 3 floats) follow the rest.
  const std::string old_bytes = bytes_of<DemoFields>(a), new_bytes = bytes_of<DemoFieldsPlus>(a);
  REQUIRE(new_bytes.size() == old_bytes.size() + sizeof(uint64_t) + 3 * sizeof(float));
  REQUIRE(new_bytes.compare(0, old_bytes.size(), old_bytes) == 0);

  // The reader: every field back, the added one too.
  Demo b = demo(9);
  std::istringstream in(new_bytes);
  REQUIRE(read_fields<DemoFieldsPlus>(in, b, "demo."));
  REQUIRE(same(a, b));
  // Bytes of the earlier list: read, the appended field absent and untouched.
  Demo c = demo(9);
  std::istringstream old_in(old_bytes);
  REQUIRE_FALSE(read_fields<DemoFieldsPlus>(old_in, c, "demo."));
  REQUIRE(c.added == demo(9).added);
  REQUIRE(c.x == a.x);

  // The copy: with the longer list the added field is copied, with the shorter not.
  Demo d = demo(9), e = demo(9);
  copy_field_values<DemoFieldsPlus>(a, d);
  copy_field_values<DemoFields>(a, e);
  REQUIRE(same(a, d));
  REQUIRE(e.added == demo(9).added);

  // A count that differs is refused by the field's name; so is a short input.
  Demo f = demo(9);
  f.x.push_back(0.0);
  std::istringstream in2(new_bytes);
  REQUIRE_THROWS_WITH(read_fields<DemoFieldsPlus>(in2, f, "demo."),
                      Catch::Contains("demo.x has 3 elements, expected 4"));
  Demo g = demo(9);
  std::istringstream cut(new_bytes.substr(0, 20));
  REQUIRE_THROWS_WITH(read_fields<DemoFieldsPlus>(cut, g, "demo."), Catch::Contains("truncated while reading demo.x"));
  Demo h = demo(9);
  h.t.pop_back();
  REQUIRE_THROWS_WITH(copy_field_values<DemoFields>(a, h), Catch::Contains("shapes of t differ"));
}

TEST_CASE("record fields: every EnvBuffers field goes through the snapshot and the copy", "[snapshot][record_fields]") {
  auto env = make_env({.name = "table", .num_envs = 3});
  const EnvBuffers base = env->buffers();
  EnvBufferFields::each([&](const char* name, const auto& acc, unsigned = kFieldPlain) {
    INFO(name);
    EnvBuffers marked = base;
    auto& v = field_of(marked, acc);
    REQUIRE(!v.empty());
    using T = typename std::decay_t<decltype(v)>::value_type;
    v.back() = static_cast<T>(v.back() + 1);  // another value in one slot
    REQUIRE(field_of(marked, acc) != field_of(base, acc));

    EnvBuffers copy = base;
    copy.copy_values_from(marked);
    CHECK(field_of(copy, acc) == field_of(marked, acc));

    SnapshotWriter w(snapshot_tag("TEST"), "test");
    write_buffers_section(w, marked);
    std::ostringstream out;
    w.finish(out);
    std::istringstream in(out.str());
    SnapshotReader r(in, snapshot_tag("TEST"), "test");
    EnvBuffers back = base;
    read_buffers_section(r, back);
    r.finish();
    CHECK(field_of(back, acc) == field_of(marked, acc));
  });
}

TEST_CASE("config fields: nav's JSON is written and read from one list", "[nav][record_fields]") {
  nlohmann::json j;
  to_json(j, default_nav_config());
  // Every key the writer puts out is one the reader requires, by its path.
  auto drop_each = [&](const nlohmann::json& node, const std::string& path, auto&& self,
                       std::vector<std::string> at) -> void {
    for (auto it = node.begin(); it != node.end(); ++it) {
      std::vector<std::string> here = at;
      here.push_back(it.key());
      const std::string key = path + "." + it.key();
      if (it->is_object() && key != "env.fetch.policy") {
        self(*it, key, self, here);
        continue;
      }
      nlohmann::json k = j;
      nlohmann::json* p = &k;
      for (size_t i = 0; i + 1 < here.size(); ++i) p = &(*p)[here[i]];
      p->erase(here.back());
      INFO(key);
      NavConfig c;
      REQUIRE_THROWS_WITH(from_json(k, c), Catch::Contains("missing config key '" + key + "'"));
    }
  };
  drop_each(j, "env", drop_each, {});
  // And what it reads back writes the same JSON.
  NavConfig c;
  from_json(j, c);
  nlohmann::json again;
  to_json(again, c);
  REQUIRE(again.dump() == j.dump());
  // Ranges sit in the list: the reader refuses what the writer would not hold.
  nlohmann::json bad = j;
  bad["box2d"]["velocity_iterations"] = 0;
  REQUIRE_THROWS_WITH(from_json(bad, c), Catch::Contains("env.box2d.velocity_iterations"));
}
