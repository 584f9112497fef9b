// The learned TIAGo body field (conditioned on the torso lift): the data's
// labels against the body rows' geometry, the lane kernel's grad_p d against
// central finite differences of its own value and against the double scalar
// twin, the shipped model in table, shelf and hri against the analytic body
// rows (and the env's lanes against evaluate_reference), and bad settings.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/arm/arm_learned_sdf.hpp"
#include "kernels/redsdf_lanes.hpp"
#include "src/core/data_dir.hpp"
#include "train/sdf_path_accuracy.hpp"
#include "train/sdf_tiago_data.hpp"
#include "tests/near.hpp"

using namespace atacom;

namespace {

std::shared_ptr<LearnedObstacle> random_body_field(float lift) {
  RedsdfArch a;
  a.pose_dim = 1;
  a.hidden = {32, 32, 24};
  a.trunk_layers = 2;
  a.side_width = 8;
  a.centre = tiago_body_centre();
  auto m = std::make_shared<RedsdfModel>(a);
  init_redsdf(*m, 7);
  const RedsdfLayer& s = m->layout.side[1];
  m->params[s.b] = 1.0f;  // rho and alpha in the blend's steep region
  m->params[s.b + 1] = 0.2f;
  auto o = std::make_shared<LearnedObstacle>();
  o->model = m;
  o->batch = std::make_shared<RedsdfBatch>(*m);
  o->pose = {lift};
  return o;
}

// The body's field as given, every other field analytic (hri's default is learned).
ArmEnvConfig body_config(ArmTask task, const std::string& spec) {
  ArmEnvConfig c = default_arm_env_config(task);
  for (auto& [key, value] : c.sdf) value = "analytic";
  c.sdf["tiago"] = spec;
  return c;
}

}  // namespace

TEST_CASE("tiago SDF data: labels are the body rows' smooth union, surface points on the body, lifts in range", "[redsdf]") {
  // The geometry is the env's body at its torso lift.
  for (ArmTask task : {ArmTask::Table, ArmTask::Hri}) {
    const ArmEnv env(default_arm_env_config(task), 1);
    const ShapeUnion b = tiago_body_geometry(env.config().torso_lift);
    REQUIRE(b.shapes.size() == env.scene().body.shapes.size());
    CHECK(b.blend == env.scene().body.blend);
    for (size_t i = 0; i < b.shapes.size(); ++i)
      for (int k = 0; k < 3; ++k) {
        CHECK(b.shapes[i].a[k] == env.scene().body.shapes[i].a[k]);
        CHECK(b.shapes[i].half[k] == env.scene().body.shapes[i].half[k]);
      }
  }
  // The head rises with the torso (so the field needs the lift).
  CHECK(tiago_body_geometry(0.3).shapes[2].a[2] - tiago_body_geometry(0.1).shapes[2].a[2] == Approx(0.2));
  // Surface samples of every primitive lie on it with the outward normal.
  Rng rng(4, 0);
  for (const Shape& s : tiago_body_geometry(0.2).shapes)
    for (int i = 0; i < 200; ++i) {
      Eigen::Vector3d p, nrm, g;
      sample_shape_surface(s, rng, p, nrm);
      CHECK(std::abs(shape_distance(s, p)) < 1e-9);
      CHECK(std::abs(nrm.norm() - 1.0) < 1e-12);
      CHECK(shape_distance(s, p + 1e-4 * nrm) == Approx(1e-4).margin(1e-9));
    }
  CHECK_THROWS_WITH(shape_surface_area(Shape::capsule({0, 0, 0}, {0, 0, 1}, 0.1, "cap")), Catch::Contains("'cap' is a capsule"));

  SdfDataConfig c = default_sdf_data_config();
  c.poses = 5;
  c.surface_points = 30;
  c.epsilons = {0.0, 0.05, -0.01};
  const SdfSamples s = make_tiago_sdf_samples(c);
  REQUIRE(s.pose_dim == 1);
  REQUIRE(int(s.poses.size()) == 5);
  REQUIRE(int(s.pose_id.size()) == s.n);
  for (float l : s.poses) CHECK((l >= 0.0f && l <= float(kTiagoSdfLiftMax)));
  int on_surface = 0;
  for (int i = 0; i < s.n; ++i) {
    const ShapeUnion body = tiago_body_geometry(s.poses[size_t(s.pose_id[size_t(i)])]);
    const Eigen::Vector3d p(s.p[size_t(3 * i)], s.p[size_t(3 * i + 1)], s.p[size_t(3 * i + 2)]);
    Eigen::Vector3d g;
    CHECK(std::abs(s.y[size_t(i)] - union_distance(body, p, &g)) < 1e-6);
    CHECK(s.y[size_t(i)] <= union_distance_exact(body, p) + 1e-6);  // the smooth union never exceeds the exact one
    CHECK((g - Eigen::Vector3d(s.grad[size_t(3 * i)], s.grad[size_t(3 * i + 1)], s.grad[size_t(3 * i + 2)])).norm() < 1e-5);  // float storage
    on_surface += std::abs(union_distance_exact(body, p)) < 1e-6;
  }
  CHECK(on_surface >= 5 * 30);  // every offset-0 sample
}

TEST_CASE("learned body lanes: grad_p d matches central finite differences, the lanes equal the scalar twin", "[redsdf][arm_env]") {
  constexpr int L = lanes::kLanes, npoi = 9;
  for (float lift : {0.1f, 0.3f}) {
    auto o = random_body_field(lift);
    Rng rng(13, 0);
    lanes::vd poi[npoi][3];
    for (int i = 0; i < npoi; ++i)
      for (int l = 0; l < L; ++l) {
        poi[i][0][l] = rng.uniform(-0.5, 1.0), poi[i][1][l] = rng.uniform(-0.7, 0.5), poi[i][2][l] = rng.uniform(0.0, 1.6);
      }
    lanes::vd d[npoi], g[npoi][3], d_only[npoi];
    learned_distance_lanes(*o, poi, npoi, d, g);
    learned_distance_lanes(*o, poi, npoi, d_only, nullptr);
    double max_d = 0, max_g = 0;
    for (int i = 0; i < npoi; ++i)
      for (int l = 0; l < L; ++l) {
        CHECK(d_only[i][l] == d[i][l]);
        Eigen::Vector3d gr;
        const double dr = learned_distance_reference(*o, {poi[i][0][l], poi[i][1][l], poi[i][2][l]}, &gr);
        max_d = std::max(max_d, std::abs(dr - d[i][l]) / (1 + std::abs(dr)));
        max_g = std::max(max_g, (gr - Eigen::Vector3d(g[i][0][l], g[i][1][l], g[i][2][l])).norm() / (1 + gr.norm()));
      }
    INFO("lift " << lift << ": lanes vs scalar twin, max rel d " << max_d << " grad " << max_g);
    CHECK(max_d < 1e-5);
    CHECK(max_g < 1e-4);
    // Central differences of the lanes' own value.
    const double h = 1e-3;
    int bad = 0, total = 0;
    for (int r = 0; r < 3; ++r) {
      lanes::vd pp[npoi][3], pm[npoi][3], dp[npoi], dm[npoi];
      for (int i = 0; i < npoi; ++i)
        for (int c = 0; c < 3; ++c) pp[i][c] = pm[i][c] = poi[i][c];
      for (int i = 0; i < npoi; ++i) pp[i][r] += h, pm[i][r] -= h;
      learned_distance_lanes(*o, pp, npoi, dp, nullptr);
      learned_distance_lanes(*o, pm, npoi, dm, nullptr);
      for (int i = 0; i < npoi; ++i)
        for (int l = 0; l < L; ++l) {
          ++total;
          bad += !near_abs_rel((dp[i][l] - dm[i][l]) / (2 * h), g[i][r][l], 2e-3, 1e-2);
        }
    }
    INFO(bad << " of " << total << " gradient entries off");
    CHECK(bad <= total / 20);  // the outliers are ReLU kinks inside the 1e-3 stencil
    // The lift is an input: the other height gives another field.
    auto other = random_body_field(lift == 0.1f ? 0.3f : 0.1f);
    lanes::vd d2[npoi];
    learned_distance_lanes(*other, poi, npoi, d2, nullptr);
    int differ = 0;
    for (int i = 0; i < npoi; ++i)
      for (int l = 0; l < L; ++l) differ += d2[i][l] != d[i][l];
    CHECK(differ > npoi * L / 2);
  }
}

TEST_CASE("arm envs with the shipped learned body: body rows within the margin of the analytic ones, lanes equal the scalar path",
          "[redsdf][arm_env]") {
  for (ArmTask task : {ArmTask::Table, ArmTask::Shelf, ArmTask::Hri}) {
    const int N = 64;
    ArmEnv an(body_config(task, "analytic"), N), le(body_config(task, "learned"), N);
    an.seed(6), le.seed(6);
    an.reset(), le.reset();
    for (int e = 0; e < N; ++e) {
      if (task == ArmTask::Hri) le.set_human_time(e, an.human_time()[size_t(e)]);
      le.set_state(e, &an.q()[size_t(e) * kArmJoints], &an.goal()[size_t(e) * 3]);
    }
    ProjectorBatch pa(an.projector_model(), N), pl(le.projector_model(), N);
    an.constraint_model(pa, 0, N);
    le.constraint_model(pl, 0, N);
    const int k = an.spec().num_constraints;
    const double margin = le.row_offset()[kRowBody] - an.row_offset()[kRowBody];
    CHECK(margin > 0.0);
    CHECK(margin < 0.05);
    CHECK(le.row_offset()[kRowScene] == an.row_offset()[kRowScene]);  // the obstacle stays analytic
    double worst = 0, worst_ref = 0;
    int near = 0;
    for (int e = 0; e < N; ++e) {
      const ArmEval ev = le.evaluate_reference(&le.q()[size_t(e) * kArmJoints]);
      for (int i = 0; i < kArmPoi; ++i) {
        const int r = kRowBody + i;
        worst_ref = std::max(worst_ref, std::abs(ev.c(r) - pl.c[size_t(e * k + r)]));
        for (int j = 0; j < kArmJoints; ++j)
          worst_ref = std::max(worst_ref, std::abs(ev.J(r, j) - pl.Jq[size_t((e * k + r) * kArmJoints + j)]) / 10);
        const double da = an.row_offset()[size_t(r)] - pa.c[size_t(e * k + r)];
        const double dl = le.row_offset()[size_t(r)] - pl.c[size_t(e * k + r)];
        if (da > 0.3) continue;
        ++near;
        worst = std::max(worst, std::abs(dl - da));
        CHECK(dl - da <= margin);  // the learned rows never claim more room than the margin covers
      }
    }
    INFO(arm_task_name(task) << ": " << near << " PoIs within 0.3 m of the body, worst |d_learned - d_analytic| " << worst
                             << ", margin " << margin << ", worst lanes vs evaluate_reference " << worst_ref);
    CHECK(near > 20);
    CHECK(worst < 0.03);
    CHECK(worst_ref < 1e-4);
  }
}

TEST_CASE("bad learned body settings fail at construction with the key or file named", "[redsdf][arm_env]") {
  CHECK_THROWS_WITH(ArmEnv(body_config(ArmTask::Table, "learnt"), 1), Catch::Contains("env.sdf.tiago"));
  CHECK_THROWS_WITH(ArmEnv(body_config(ArmTask::Shelf, "learned:/nonexistent/sdf"), 1), Catch::Contains("cannot be opened"));
  CHECK_THROWS_WITH(ArmEnv(body_config(ArmTask::Hri, "learned:data/sdf/table"), 1),
                    Catch::Contains("holds object 'table', expected 'tiago'"));
  const auto base = std::filesystem::temp_directory_path() / ("atacom_body_sdf_" + std::to_string(::getpid()));
  std::filesystem::remove_all(base);
  // A body model without the torso input.
  RedsdfArch a;
  a.hidden = {8, 8};
  a.trunk_layers = 1;
  a.side_width = 4;
  RedsdfModel m(a);
  init_redsdf(m, 1);
  m.manifest = {{"object", "tiago"}, {"safety_margin", 0.02}};
  save_redsdf(m, (base / "static").string());
  CHECK_THROWS_WITH(ArmEnv(body_config(ArmTask::Table, "learned:" + (base / "static").string()), 1),
                    Catch::Contains("takes the torso lift as its one pose input"));
  // The shipped file with one byte flipped.
  std::filesystem::create_directories(base / "flip");
  std::filesystem::copy_file(data_dir() + "/sdf/tiago/redsdf.bin", base / "flip" / "redsdf.bin");
  {
    std::fstream f(base / "flip" / "redsdf.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(-100, std::ios::end);
    char c = 0;
    f.read(&c, 1);
    c = char(c ^ 0x20);
    f.seekp(-100, std::ios::end);
    f.write(&c, 1);
  }
  CHECK_THROWS_WITH(ArmEnv(body_config(ArmTask::Table, "learned:" + (base / "flip").string()), 1), Catch::Contains("checksum"));
  std::filesystem::remove_all(base);
  // The flag switches the body with the env's own field on every arm env.
  CHECK(sdf_flag_override("shelf", "learned") == nlohmann::json{{"sdf", {{"shelf", "learned"}, {"tiago", "learned"}}}});
  CHECK(sdf_flag_override("hri", "analytic") ==
        nlohmann::json{{"sdf", {{"human", "analytic"}, {"table", "analytic"}, {"tiago", "analytic"}}}});
}

TEST_CASE("sdf-paths on the body field: every point counted, the band's over-estimate within the body margin", "[redsdf][arm_env]") {
  SdfPathConfig c;
  c.env = "table";
  c.field = "body";
  c.steps = 2000;
  c.envs = 16;
  c.safety = "none";
  const auto r = sdf_path_accuracy(c);
  CHECK(r["object"] == "tiago");
  CHECK(r["field"] == "body");
  const long points = r["points"];
  CHECK(points > 0);
  CHECK(points <= 2000L * kArmPoi);
  CHECK(r["near"]["points"].get<long>() + r["mid"]["points"].get<long>() + r["far"]["points"].get<long>() == points);
  const double margin = r["margin"];
  CHECK(margin > 0.0);
  // Some PoIs (the shoulder's) sit close to the torso: the near/mid bins are not empty.
  CHECK(r["near"]["points"].get<long>() + r["mid"]["points"].get<long>() > 0);
  CHECK(r["max_overestimate_band"].get<double>() < margin);
  CHECK(r["clear_while_inside"].get<long>() == 0);
  c.field = "elbow";
  CHECK_THROWS_WITH(sdf_path_accuracy(c), Catch::Contains("field 'elbow'"));
}
