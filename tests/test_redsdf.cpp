// ReDSDF model and batched inference: the reference gradient against finite
// differences, the batched float32 kernel against the double reference and
// against its own finite differences, thread-count independence, shared vs
// per-point poses, and the weight file (round trip, corruption, mismatch).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "kernels/redsdf_batch.hpp"
#include "src/core/redsdf_model.hpp"

using namespace atacom;
using Eigen::Vector3d;

namespace {
RedsdfModel test_model(int pose_dim) {
  RedsdfArch a;
  a.pose_dim = pose_dim;
  a.hidden = {24, 20, 16};
  a.trunk_layers = 2;
  a.side_width = 8;
  a.centre = {0.1, -0.2, 0.3};
  RedsdfModel m(a);
  init_redsdf(m, 7);
  // Side-head biases that put rho and alpha in the blend's steep region.
  const RedsdfLayer& s = m.layout.side[1];
  m.params[s.b] = 1.0f;
  m.params[s.b + 1] = 0.2f;
  m.manifest["object"] = "test";
  return m;
}
struct Points {
  std::vector<float> p, pose;
  int n = 0;
};
Points random_points(int n, int pose_dim, uint64_t seed) {
  Points s;
  s.n = n;
  Rng rng(seed, 1);
  for (int i = 0; i < 3 * n; ++i) s.p.push_back(float(rng.uniform(-1.5, 1.5)));
  for (int i = 0; i < pose_dim * n; ++i) s.pose.push_back(float(rng.uniform(-1, 1)));
  return s;
}
}  // namespace

TEST_CASE("redsdf reference gradient matches finite differences", "[redsdf]") {
  const RedsdfModel m = test_model(2);
  Rng rng(3, 0);
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    const Vector3d p(rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 1.5));
    const double pose[2] = {rng.uniform(-1, 1), rng.uniform(-1, 1)};
    Vector3d g;
    redsdf_reference(m, p, pose, &g);
    Vector3d fd;
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Vector3d a = p, b = p;
      a(k) += h, b(k) -= h;
      fd(k) = (redsdf_reference(m, a, pose) - redsdf_reference(m, b, pose)) / (2 * h);
    }
    INFO("point " << p.transpose() << " grad " << g.transpose() << " fd " << fd.transpose());
    CHECK((g - fd).norm() <= 1e-5 * (1 + g.norm()));
    ++checked;
  }
  CHECK(checked == 200);
}

TEST_CASE("redsdf batched float32 matches the double reference and its own finite differences", "[redsdf]") {
  for (int pose_dim : {0, 3}) {
    const RedsdfModel m = test_model(pose_dim);
    RedsdfBatch batch(m);
    const int n = 1000;  // not a multiple of the block: a partial last block
    const Points s = random_points(n, pose_dim, 11);
    std::vector<float> d(n), g(3 * n);
    batch.evaluate(s.p.data(), s.pose.data(), false, n, d.data(), g.data());
    std::vector<float> d_only(n);
    batch.evaluate(s.p.data(), s.pose.data(), false, n, d_only.data(), nullptr);
    CHECK(d_only == d);
    double max_d = 0, max_g = 0, max_fd = 0;
    for (int i = 0; i < n; ++i) {
      const Vector3d p(s.p[3 * i], s.p[3 * i + 1], s.p[3 * i + 2]);
      std::vector<double> pose(s.pose.begin() + pose_dim * i, s.pose.begin() + pose_dim * (i + 1));
      Vector3d gr;
      const double dr = redsdf_reference(m, p, pose.data(), &gr);
      max_d = std::max(max_d, std::abs(dr - d[i]) / (1 + std::abs(dr)));
      max_g = std::max(max_g, (gr - Vector3d(g[3 * i], g[3 * i + 1], g[3 * i + 2])).norm() / (1 + gr.norm()));
    }
    // Float finite differences of the batched kernel itself (step 1e-3, central).
    for (int i = 0; i < 50; ++i) {
      for (int k = 0; k < 3; ++k) {
        float pa[3] = {s.p[3 * i], s.p[3 * i + 1], s.p[3 * i + 2]}, pb[3] = {pa[0], pa[1], pa[2]};
        pa[k] += 1e-3f, pb[k] -= 1e-3f;
        float da, db;
        batch.evaluate(pa, s.pose.data() + pose_dim * i, true, 1, &da, nullptr);
        batch.evaluate(pb, s.pose.data() + pose_dim * i, true, 1, &db, nullptr);
        max_fd = std::max(max_fd, std::abs((da - db) / 2e-3 - g[3 * i + k]));
      }
    }
    INFO("pose_dim " << pose_dim << " max rel d error " << max_d << " grad " << max_g << " fd " << max_fd);
    CHECK(max_d < 1e-5);
    CHECK(max_g < 1e-4);
    CHECK(max_fd < 2e-2);  // ReLU kinks inside a 1e-3 step are the rare outliers here
  }
}

TEST_CASE("redsdf batched results do not depend on threads, blocks or pose sharing", "[redsdf]") {
  const RedsdfModel m = test_model(2);
  RedsdfBatch batch(m);
  const int n = 3000;
  Points s = random_points(n, 2, 5);
  std::vector<float> d1(n), g1(3 * n), d2(n), g2(3 * n);
  set_num_threads(1);
  batch.evaluate(s.p.data(), s.pose.data(), false, n, d1.data(), g1.data());
  set_num_threads(2);
  batch.evaluate(s.p.data(), s.pose.data(), false, n, d2.data(), g2.data());
  set_num_threads(0);
  CHECK(d1 == d2);
  CHECK(g1 == g2);
  // A shared pose equals the same pose repeated per point.
  std::vector<float> rep;
  for (int i = 0; i < n; ++i) rep.insert(rep.end(), s.pose.begin(), s.pose.begin() + 2);
  batch.evaluate(s.p.data(), rep.data(), false, n, d1.data(), g1.data());
  batch.evaluate(s.p.data(), s.pose.data(), true, n, d2.data(), g2.data());
  CHECK(d1 == d2);
  CHECK(g1 == g2);
}

TEST_CASE("redsdf weight file round trip and clear errors for bad files", "[redsdf]") {
  const auto dir = std::filesystem::temp_directory_path() / ("atacom_redsdf_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  RedsdfModel m = test_model(1);
  m.manifest["data_seed"] = 42;
  save_redsdf(m, dir.string());
  REQUIRE(std::filesystem::exists(dir / "manifest.json"));
  const RedsdfModel r = load_redsdf(dir.string(), "test");
  CHECK(r.params == m.params);
  CHECK(r.arch.hidden == m.arch.hidden);
  CHECK(r.arch.centre == m.arch.centre);
  CHECK(r.manifest.at("data_seed") == 42);
  CHECK_THROWS_WITH(load_redsdf(dir.string(), "shelf"), Catch::Contains("holds object 'test', expected 'shelf'"));
  CHECK_THROWS_WITH(load_redsdf((dir / "missing").string()), Catch::Contains("cannot be opened"));
  const auto bin = dir / "redsdf.bin";
  std::string bytes;
  {
    std::ifstream f(bin, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  }
  auto write = [&](const std::string& b) {
    std::ofstream f(bin, std::ios::binary | std::ios::trunc);
    f.write(b.data(), std::streamsize(b.size()));
  };
  std::string flipped = bytes;
  flipped[flipped.size() / 2] ^= 0x10;  // a parameter byte
  write(flipped);
  CHECK_THROWS_WITH(load_redsdf(dir.string()), Catch::Contains("checksum mismatch"));
  write(bytes.substr(0, bytes.size() - 9));
  CHECK_THROWS_WITH(load_redsdf(dir.string()), Catch::Contains("truncated"));
  write(bytes + "x");
  CHECK_THROWS_WITH(load_redsdf(dir.string()), Catch::Contains("longer than its header says"));
  write("not a model");
  CHECK_THROWS_WITH(load_redsdf(dir.string()), Catch::Contains("not a ReDSDF weight file"));
  write(bytes);
  CHECK_NOTHROW(load_redsdf(dir.string()));
  std::filesystem::remove_all(dir);
}

TEST_CASE("redsdf architecture rejects bad sizes with the field name", "[redsdf]") {
  RedsdfArch a;
  a.trunk_layers = 4;
  CHECK_THROWS_WITH(a.validate(), Catch::Contains("redsdf.trunk_layers"));
  a = RedsdfArch{};
  a.hidden = {64, 0, 64};
  CHECK_THROWS_WITH(a.validate(), Catch::Contains("redsdf.hidden"));
  nlohmann::json j = RedsdfArch{};
  j["depth"] = 3;
  CHECK_THROWS_WITH(j.get<RedsdfArch>(), Catch::Contains("depth"));
}
