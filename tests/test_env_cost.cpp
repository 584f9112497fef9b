// The two per-step costs (include/atacom/env.hpp, docs/training.md "Cost"):
// `cost` is 1 exactly when a row exceeds its stated tolerance or a cost
// event (collision, joint limit) happened, `cost_continuous` is
// max(0, max_i c_i), for every env under every safety layer; snapshots of
// earlier builds (continuous cost in the cost slot) still load; the trainer
// sums the 0/1 cost into train_cost and averages it per evaluation episode
// (eval_cost_mean); a progress.csv of an earlier build resumes with NaN in
// the columns added since.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/rng.hpp"
#include "atacom/trainer.hpp"
#include "src/core/snapshot.hpp"
#include "train/run_files.hpp"
#include "tests/test_files.hpp"

using namespace atacom;
namespace fs = std::filesystem;

namespace {

int info_column(const EnvSpec& s, const std::string& name) {
  for (size_t c = 0; c < s.info_names.size(); ++c)
    if (s.info_names[c] == name) return int(c);
  return -1;
}

}  // namespace

namespace {

// Random actions through every layer of env `name`: the 0/1 cost and the
// continuous cost against their definitions, step by step.
// Returns the steps with a cost event under the raw env.
int64_t check_cost_rule(const std::string& name, const nlohmann::json& config = nlohmann::json::object()) {
  int64_t raw_event_steps = 0;
  {
    const bool constrained = env_entry(name).has_constraints;
    for (SafetyLayer layer : safety_layers()) {
      if (!layer.is_none() && !constrained) continue;
      INFO(name << " under " << layer.name());
      const int N = 8;
      auto env = make_env(EnvRequest{name, N, layer, config});
      const EnvSpec& s = env->spec();
      const int k = s.num_constraints, ni = int(s.info_names.size());
      std::vector<int> events;
      for (const std::string& e : s.cost_events) {
        const int c = info_column(s, e);
        REQUIRE(c >= 0);  // every event names an info column
        events.push_back(c);
      }
      if (constrained) CHECK(!events.empty());
      env->seed(5);
      Rng rng(5, 77);
      std::vector<double> a(size_t(N) * s.act_dim);
      int64_t ones = 0, event_steps = 0, row_steps = 0;
      for (int t = 0; t < 400; ++t) {
        for (double& x : a) x = rng.uniform(-1.0, 1.0);
        env->step(a.data());
        const EnvBuffers& b = env->buffers();
        for (int i = 0; i < N; ++i) {
          bool row = false, event = false;
          double mx = 0.0;
          for (int r = 0; r < k; ++r) {
            const double c = b.constraints[size_t(i) * k + r];
            row = row || c > s.constraint_tolerance[size_t(r)];
            mx = std::max(mx, c);
          }
          for (int c : events) event = event || b.info[size_t(i) * ni + c] != 0.0f;
          const float want = row || event ? 1.0f : 0.0f;
          if (b.cost[size_t(i)] != want) FAIL_CHECK("step " << t << " env " << i << ": cost " << b.cost[size_t(i)]);
          if (b.cost_continuous[size_t(i)] != float(mx))
            FAIL_CHECK("step " << t << " env " << i << ": cost_continuous " << b.cost_continuous[size_t(i)] << " != " << mx);
          ones += want != 0.0f;
          event_steps += event;
          row_steps += row;
        }
      }
      if (!constrained) CHECK(ones == 0);
      // A random policy in the raw arm envs exceeds rows and collides: both
      // halves of the rule are exercised.
      if (layer.is_none() && (name == "table" || name == "hri")) {
        CHECK(row_steps > 0);
        CHECK(ones >= row_steps);
      }
      if (layer.is_none() && name == "shelf") CHECK(event_steps > 0);
      if (layer.is_none()) raw_event_steps = event_steps;
    }
  }
  return raw_event_steps;
}

}  // namespace

TEST_CASE("env cost: cost is 1 exactly when a row exceeds its tolerance or a cost event happened", "[cost]") {
  for (const std::string& name : env_names())
    if (name != "hri" && name != "hri-upright") check_cost_rule(name);
}

// HRI-Sim takes about 1.7 s to build per layer: slow label.
TEST_CASE("env cost: the cost rule on HRI-Sim under every layer", "[cost][slow]") {
  check_cost_rule("hri");
  check_cost_rule("hri-upright");
}

TEST_CASE("env cost: env.hri.spill_cost makes a spill a cost event, and nothing else moves", "[cost][slow]") {
  const nlohmann::json on = {{"hri", {{"spill_cost", true}}}};
  CHECK(resolve_env_config("hri", nlohmann::json::object())["hri"]["spill_cost"] == false);  // off by default
  const EnvSpec plain = make_env(EnvRequest{"hri", 1})->spec();
  const EnvSpec with = make_env(EnvRequest{"hri", 1, SafetyLayer::None, on})->spec();
  CHECK(plain.cost_events == std::vector<std::string>{"collision", "joint_limit_violation"});
  CHECK(with.cost_events == std::vector<std::string>{"collision", "joint_limit_violation", "spill"});
  const int64_t events_off = check_cost_rule("hri");
  const int64_t events_on = check_cost_rule("hri", on);
  CHECK(events_on > events_off);  // random actions spill in most episodes
  // Reward, state and the other columns keep their bits: only cost differs.
  auto a = make_env(EnvRequest{"hri", 4});
  auto b = make_env(EnvRequest{"hri", 4, SafetyLayer::None, on});
  a->seed(9);
  b->seed(9);
  Rng rng(9, 1);
  std::vector<double> act(size_t(4) * a->spec().act_dim);
  int64_t spill_costs = 0;
  const int spill = info_column(with, "spill"), ni = int(with.info_names.size());
  for (int t = 0; t < 300; ++t) {
    for (double& x : act) x = rng.uniform(-1.0, 1.0);
    a->step(act.data());
    b->step(act.data());
    const EnvBuffers &x = a->buffers(), &y = b->buffers();
    REQUIRE(x.reward == y.reward);
    REQUIRE(x.obs == y.obs);
    REQUIRE(x.info == y.info);
    REQUIRE(x.cost_continuous == y.cost_continuous);
    for (int i = 0; i < 4; ++i) {
      if (y.info[size_t(i) * ni + spill] != 0.0f) {
        CHECK(y.cost[size_t(i)] == 1.0f);
        spill_costs += x.cost[size_t(i)] == 0.0f;
      } else {
        CHECK(y.cost[size_t(i)] == x.cost[size_t(i)]);
      }
    }
  }
  CHECK(spill_costs > 0);
  // The key enters the snapshot fingerprint only when on: an env with it
  // refuses a snapshot of one without, and an explicit false is the default.
  std::ostringstream saved;
  a->save_state(saved);
  std::istringstream into_on(saved.str()), into_off(saved.str());
  CHECK_THROWS_WITH(b->load_state(into_on), Catch::Contains("different env config"));
  auto off = make_env(EnvRequest{"hri", 4, SafetyLayer::None, {{"hri", {{"spill_cost", false}}}}});
  CHECK_NOTHROW(off->load_state(into_off));
  // A build before the key fingerprinted the config without it: its
  // snapshots carry that fingerprint, and today's off env writes the same.
  nlohmann::json before = resolve_env_config("hri", nlohmann::json::object());
  before["hri"].erase("spill_cost");
  std::istringstream head(saved.str());
  SnapshotReader r(head, snapshot_tag("ARM "), "hri env");
  CHECK_NOTHROW(read_head_section(r, 4, snapshot_fingerprint(before.dump())));
  CHECK(env_config_fingerprint_form(resolve_env_config("hri", on))["hri"]["spill_cost"] == true);  // kept when on
}

TEST_CASE("env cost: a snapshot of an earlier build (continuous cost in the cost slot) loads", "[cost]") {
  auto env = make_env(EnvRequest{"pendulum", 3});
  EnvBuffers b = env->buffers();
  for (int i = 0; i < 3; ++i) b.cost[size_t(i)] = float(i) * 0.25f;  // the old continuous values
  // The layout before cost_continuous: the same arrays without the last one.
  SnapshotWriter w(snapshot_tag("TEST"), "test");
  {
    std::ostream& s = w.section(snapshot_tag("BUFS"));
    bin::write_vec(s, b.obs);
    bin::write_vec(s, b.final_obs);
    bin::write_vec(s, b.reward);
    bin::write_vec(s, b.cost);
    bin::write_vec(s, b.terminated);
    bin::write_vec(s, b.truncated);
    bin::write_vec(s, b.constraints);
    bin::write_vec(s, b.info);
    bin::write_vec(s, b.episode_return);
    bin::write_vec(s, b.episode_length);
  }
  std::ostringstream out;
  w.finish(out);
  std::istringstream in(out.str());
  SnapshotReader r(in, snapshot_tag("TEST"), "test");
  EnvBuffers got = env->buffers();
  read_buffers_section(r, got);
  r.finish();
  CHECK(got.cost_continuous == std::vector<float>{0.0f, 0.25f, 0.5f});
  CHECK(got.cost == std::vector<float>{0.0f, 1.0f, 1.0f});
  // and today's layout round-trips both
  SnapshotWriter w2(snapshot_tag("TEST"), "test");
  b.cost = {0.0f, 1.0f, 0.0f};
  b.cost_continuous = {0.0f, 0.5f, 0.0f};
  write_buffers_section(w2, b);
  std::ostringstream out2;
  w2.finish(out2);
  std::istringstream in2(out2.str());
  SnapshotReader r2(in2, snapshot_tag("TEST"), "test");
  read_buffers_section(r2, got);
  r2.finish();
  CHECK(got.cost == b.cost);
  CHECK(got.cost_continuous == b.cost_continuous);
}

TEST_CASE("env cost: train_cost and eval_cost_mean in progress.csv and summary.json, for learners and the others",
          "[cost]") {
  const std::string base = (fs::temp_directory_path() / ("atacom_cost_" + std::to_string(::getpid()))).string();
  fs::remove_all(base);
  for (const char* algo : {"sac", "random", "atacom-sac"}) {
    INFO(algo);
    const std::string dir = base + "/" + algo;
    TrainOptions o;
    o.out_dir = dir;
    const RunConfig rc = resolve_run_config(
        {{"train", {{"env", "table"}, {"algo", algo}, {"steps", 600}, {"eval_every", 300}, {"eval_episodes", 2}}}});
    const TrainSummary s = run_training(rc, o);
    const nlohmann::json& j = s.summary;
    REQUIRE(j.contains("train_cost"));
    REQUIRE(j.contains("eval_cost_mean"));
    CHECK(j["eval_cost_mean"].get<double>() >= j["violations"].get<double>());
    CHECK(j["eval_cost_mean"].get<double>() == Approx(s.final_eval.cost_mean));
    const int64_t tc = j["train_cost"].get<int64_t>();
    CHECK(tc >= j["train_violations"].get<int64_t>());
    CHECK(tc >= j.value("train_collisions", 0.0));
    CHECK(tc <= j["env_steps"].get<int64_t>());
    if (std::string(algo) == "random") CHECK(tc == 0);  // evaluated only: no training step
    if (std::string(algo) == "sac") CHECK(tc > 0);      // untrained SAC in the raw table env
    // The last progress row holds the same totals.
    std::istringstream csv(slurp(dir + "/progress.csv"));
    std::string header, row, last;
    std::getline(csv, header);
    while (std::getline(csv, row)) last = row;
    auto split = [](const std::string& line) {  // keeps empty cells (the never-met target columns)
      std::vector<std::string> out(1);
      for (char ch : line) {
        if (ch == ',') out.emplace_back();
        else out.back().push_back(ch);
      }
      return out;
    };
    const std::vector<std::string> h = split(header), v = split(last);
    REQUIRE(h.size() == v.size());
    const auto col = [&](const std::string& n) { return size_t(std::find(h.begin(), h.end(), n) - h.begin()); };
    REQUIRE(col("train_cost") < h.size());
    REQUIRE(col("eval_cost_mean") < h.size());
    CHECK(std::stod(v[col("train_cost")]) == double(tc));
    CHECK(std::stod(v[col("eval_cost_mean")]) == Approx(j["eval_cost_mean"].get<double>()).epsilon(1e-8));
  }
  fs::remove_all(base);
}

TEST_CASE("env cost: a progress.csv of an earlier build resumes with NaN in the columns added since", "[cost]") {
  const std::string path = (fs::temp_directory_path() / ("atacom_cost_csv_" + std::to_string(::getpid()))).string();
  {
    std::ofstream f(path);
    f << "env_steps,violations,train_violations\n10,0.5,3\n20,0.25,4\n30,1,9\n";
  }
  ProgressFile p(path, {"env_steps", "violations", "eval_cost_mean", "train_violations", "train_cost"});
  p.restore(2);
  REQUIRE(p.rows() == 2);
  CHECK(p.series(0) == std::vector<double>{10, 20});
  CHECK(p.series(3) == std::vector<double>{3, 4});
  CHECK(std::isnan(p.series(2)[1]));
  CHECK(std::isnan(p.series(4)[0]));
  CHECK(slurp(path) == "env_steps,violations,eval_cost_mean,train_violations,train_cost\n10,0.5,nan,3,nan\n"
                       "20,0.25,nan,4,nan\n");
  // A column this run does not know is refused.
  {
    std::ofstream f(path);
    f << "env_steps,mystery\n10,1\n";
  }
  CHECK_THROWS_WITH(p.restore(1), Catch::Contains("'mystery' is not one of this run's"));
  fs::remove(path);
}
