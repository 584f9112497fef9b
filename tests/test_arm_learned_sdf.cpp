// Learned obstacle fields in the arm envs: the shipped table and shelf models
// placed in the scene (yaw 90 and 180) agree with the analytic rows, bad
// "sdf" settings fail before any step with the key named, and random-alpha
// ATACOM rollouts with learned rows (obstacle and robot body) never collide
// with the exact geometry.
#include <catch2/catch.hpp>

#include "atacom/projector.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "src/core/data_dir.hpp"
#include "src/core/redsdf_model.hpp"
#include "tests/test_files.hpp"
#include "train/rollout.hpp"

using namespace atacom;

namespace {
// The env's static object's field as given, the others analytic (hri: its table, key "table").
ArmEnvConfig config_with(ArmTask task, const std::string& spec) {
  ArmEnvConfig c = default_arm_env_config(task);
  if (task == ArmTask::Hri) c.sdf = {{"table", spec}, {"human", "analytic"}, {"tiago", "analytic"}};
  else c.sdf = {{arm_task_name(task), spec}};
  return c;
}
}  // namespace

TEST_CASE("learned obstacle rows agree with the analytic rows near the object", "[arm_env][redsdf]") {
  for (ArmTask task : {ArmTask::Table, ArmTask::Shelf, ArmTask::Hri}) {
    const int N = 64;
    ArmEnv an(config_with(task, "analytic"), N), le(config_with(task, "learned"), N);
    an.seed(5), le.seed(5);
    an.reset(), le.reset();
    // The learned env in the analytic env's start states (its own starts differ: its thresholds are larger).
    for (int e = 0; e < N; ++e) {
      if (task == ArmTask::Hri) le.set_human_time(e, an.human_time()[size_t(e)]);
      le.set_state(e, &an.q()[size_t(e) * kArmJoints], &an.goal()[size_t(e) * 3]);
    }
    ProjectorBatch pa(an.projector_model(), N), pl(le.projector_model(), N);
    an.constraint_model(pa, 0, N);
    le.constraint_model(pl, 0, N);
    const int k = an.spec().num_constraints;
    const double blend_err = (an.scene().obstacle.shapes.size() - 1) * an.scene().obstacle.blend / 4;
    const double margin = le.row_offset()[kRowScene] - an.row_offset()[kRowScene];
    CHECK(margin > 0.0);
    CHECK(margin < 0.05);
    double worst = 0;
    int near = 0;
    for (int e = 0; e < N; ++e)
      for (int i = 0; i < kArmPoi; ++i) {
        const int r = kRowScene + i;
        const double da = an.row_offset()[size_t(r)] - pa.c[size_t(e * k + r)];
        const double dl = le.row_offset()[size_t(r)] - pl.c[size_t(e * k + r)];
        if (da > 0.3) continue;
        ++near;
        worst = std::max(worst, std::abs(dl - da));
      }
    INFO(arm_task_name(task) << ": " << near << " PoIs within 0.3 m, worst |d_learned - d_analytic| " << worst);
    CHECK(near > (task == ArmTask::Hri ? 10 : 20));  // HRI's starts keep the cup above a smaller table
    CHECK(worst < 0.03 + blend_err);
  }
}

TEST_CASE("bad learned-field settings fail at construction with the key named", "[arm_env][redsdf]") {
  ArmEnvConfig c = default_arm_env_config(ArmTask::Table);
  c.sdf = {{"shelf", "learned"}};
  CHECK_THROWS_WITH(ArmEnv(c, 1), Catch::Contains("env.sdf.shelf"));
  CHECK_THROWS_WITH(ArmEnv(config_with(ArmTask::Table, "learnt"), 1), Catch::Contains("must be analytic, learned or learned:<dir>"));
  CHECK_THROWS_WITH(ArmEnv(config_with(ArmTask::Table, "learned:/nonexistent/sdf"), 1), Catch::Contains("cannot be opened"));
  CHECK_THROWS_WITH(ArmEnv(config_with(ArmTask::Table, "learned:data/sdf/shelf"), 1),
                    Catch::Contains("holds object 'shelf', expected 'table'"));
  // HRI's table is a field of its own (data/sdf/hri_table) under the key "table".
  CHECK_THROWS_WITH(ArmEnv(config_with(ArmTask::Hri, "learned:data/sdf/table"), 1),
                    Catch::Contains("holds object 'table', expected 'hri_table'"));
  ArmEnvConfig hri = default_arm_env_config(ArmTask::Hri);
  hri.sdf["shelf"] = "learned";
  CHECK_THROWS_WITH(ArmEnv(hri, 1), Catch::Contains("env.sdf.shelf"));
  CHECK(sdf_flag_override("table", "learned") == nlohmann::json{{"sdf", {{"table", "learned"}, {"tiago", "learned"}}}});
  CHECK(sdf_flag_override("nav", "analytic").empty());
  CHECK_THROWS_WITH(sdf_flag_override("nav", "learned"), Catch::Contains("no field with a shipped learned model"));
}

// A process samples the goal library once per config and field weights
// (ArmModel::build_libraries): a field rewritten in the same directory is a
// new key, so the library follows the weights, never an earlier file's. (That
// a key is sampled once is seen only in time: hri construction under ASan.)
TEST_CASE("arm goal library: equal for the same config and field, a field rewritten in place samples anew",
          "[arm_env][redsdf]") {
  const std::string dir = tmp_dir("goal_library_field");
  const RedsdfModel shipped = load_redsdf(data_dir() + "/sdf/table", "table");
  save_redsdf(shipped, dir);
  const ArmEnvConfig c = config_with(ArmTask::Table, "learned:" + dir);
  const ArmEnv first(c, 1), again(c, 1);
  REQUIRE(!first.arm_model()->goal_lib_q.empty());
  CHECK(again.arm_model()->goal_lib_q == first.arm_model()->goal_lib_q);
  // A wider margin keeps the library's candidates further from the table: another library.
  RedsdfModel wide = shipped;
  wide.manifest["safety_margin"] = shipped.manifest["safety_margin"].get<double>() + 0.02;
  save_redsdf(wide, dir);
  const ArmEnv wider(c, 1);
  CHECK(wider.arm_model()->goal_lib_q != first.arm_model()->goal_lib_q);
  // Back to the first weights: the first library again.
  save_redsdf(shipped, dir);
  CHECK(ArmEnv(c, 1).arm_model()->goal_lib_q == first.arm_model()->goal_lib_q);
  std::filesystem::remove_all(dir);
}

// --sdf learned: the obstacle's and the robot body's learned fields together.
TEST_CASE("random-alpha ATACOM with learned table/shelf and body fields: zero exact-geometry collisions", "[arm_env][redsdf][slow]") {
  for (const char* env : {"table", "shelf"}) {
    RolloutConfig rc;
    rc.env = env;
    rc.policy = "random";
    rc.steps = 200000;
    rc.envs = 256;
    rc.seed = 11;
    rc.env_config = sdf_flag_override(env, "learned");
    const nlohmann::json r = run_rollout(rc);
    INFO(env << ": " << r.dump());
    CHECK(r["collisions"].get<double>() == 0);
    CHECK(r["nonfinite_constraints"].get<double>() == 0);
  }
}
