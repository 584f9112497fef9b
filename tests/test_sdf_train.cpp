// ReDSDF training: exact labels in the data, a short run that lowers the
// validation error, writes its files and a loadable model, and gives the same
// weights for the same seeds with 1 and 2 threads.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "atacom/parallel.hpp"
#include "envs/arm/arm_scene.hpp"
#include "envs/arm/tiago_model.hpp"
#include "train/redsdf_train.hpp"

using namespace atacom;

TEST_CASE("sdf data: labels are the scene's smooth union (never above the exact distance) or the exact one", "[redsdf]") {
  const ShapeUnion table = sdf_object_geometry("table");
  SdfDataConfig c = default_sdf_data_config();
  c.surface_points = 300;
  const SdfSamples s = make_static_sdf_samples(table, c);
  CHECK(s.n == 300 * int(c.epsilons.size()) + int(std::lround(0.2 * 300 * int(c.epsilons.size()))));
  int near = 0;
  for (int i = 0; i < s.n; ++i) {
    const Eigen::Vector3d p(s.p[size_t(3 * i)], s.p[size_t(3 * i + 1)], s.p[size_t(3 * i + 2)]);
    CHECK(std::abs(s.y[size_t(i)] - union_distance(table, p)) < 1e-6);
    CHECK(s.y[size_t(i)] <= union_distance_exact(table, p) + 1e-6);
    near += std::abs(s.y[size_t(i)]) < 0.1;
  }
  CHECK(near > s.n / 2);
  CHECK(table.blend > 0.0);
  c.blend = 0.0;
  const SdfSamples e = make_static_sdf_samples(table, c);
  for (int i = 0; i < e.n; i += 7) {
    const Eigen::Vector3d p(e.p[size_t(3 * i)], e.p[size_t(3 * i + 1)], e.p[size_t(3 * i + 2)]);
    CHECK(std::abs(e.y[size_t(i)] - union_distance_exact(table, p)) < 1e-6);
  }
  CHECK_THROWS_WITH(sdf_object_geometry("human"), Catch::Contains("static-object geometry exists for table, shelf and hri_table only"));
  CHECK_THROWS_WITH(sdf_object_geometry("tiago"), Catch::Contains("static-object geometry exists for table, shelf and hri_table only"));
  // HRI's table in its object frame: the env's box, moved back by the scene's placement.
  Eigen::Vector3d centre;
  const ShapeUnion ht = sdf_object_geometry("hri_table", &centre);
  REQUIRE(ht.shapes.size() == 1);
  CHECK((centre - Eigen::Vector3d(0.0, 0.0, 0.4)).norm() < 1e-12);
  const ArmSceneConfig sc = default_arm_scene_config(ArmTask::Hri);
  const ArmScene scene = build_arm_scene(sc, load_tiago_arm_model(0.3));
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  arm_object_placement(sc, R, t);
  for (int k = 0; k < 3; ++k) {
    CHECK(std::abs(ht.shapes[0].a[k] + t(k) - scene.obstacle.shapes[0].a[k]) < 1e-12);
    CHECK(ht.shapes[0].half[k] == scene.obstacle.shapes[0].half[k]);
  }
}

TEST_CASE("sdf training: short run lowers the error, writes its files, same weights for 1 and 2 threads", "[redsdf]") {
  SdfTrainConfig c = default_sdf_train_config("shelf");
  c.arch.hidden = {16, 16, 16};
  c.arch.side_width = 8;
  c.data.surface_points = 200;
  c.batch = 256;
  c.max_epochs = 4;
  const auto base = std::filesystem::temp_directory_path() / ("atacom_sdf_train_" + std::to_string(::getpid()));
  std::filesystem::remove_all(base);
  set_num_threads(1);
  const nlohmann::json m1 = train_sdf(c, (base / "a").string(), "test", false);
  set_num_threads(2);
  const nlohmann::json m2 = train_sdf(c, (base / "b").string(), "test", false);
  set_num_threads(0);
  for (const char* f : {"redsdf.bin", "manifest.json", "progress.csv", "learning_curve.svg", "config.json"})
    CHECK(std::filesystem::exists(base / "a" / f));
  const RedsdfModel a = load_redsdf((base / "a").string(), "shelf"), b = load_redsdf((base / "b").string(), "shelf");
  CHECK(a.params == b.params);
  CHECK(m1.at("best_val_wmse") == m2.at("best_val_wmse"));
  CHECK(m1.at("safety_margin").get<double>() > 0.0);
  // The validation error falls from the first epoch to the best one.
  std::ifstream csv(base / "a" / "progress.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  const double v1 = std::stod(first.substr(first.find(',', first.find(',') + 1) + 1));
  CHECK(m1.at("best_val_wmse").get<double>() < v1);
  std::filesystem::remove_all(base);
}
