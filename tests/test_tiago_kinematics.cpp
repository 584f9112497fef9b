// FK of the TIAGo++ arm: published test values, finite differences, and the
// batched SIMD kernel against the scalar reference.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/data_dir.hpp"
#include "atacom/rng.hpp"
#include "envs/arm/tiago_kinematics.hpp"

using namespace atacom;

namespace {
nlohmann::json arm_json() {
  std::ifstream in(data_file("tiago_arm.json"));
  return nlohmann::json::parse(in);
}
Eigen::Vector3d v3(const nlohmann::json& j) { return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>()); }
Eigen::Matrix3d m3(const nlohmann::json& j) {
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = j[r][c];
  return R;
}
ArmQ random_joint_q(const TiagoArmModel& m, Rng& rng) {
  ArmQ q;
  for (int j = 0; j < kArmJoints; ++j) q(j) = rng.uniform(m.lower[j], m.upper[j]);
  return q;
}
}  // namespace

TEST_CASE("arm FK matches the published test values to 1e-6", "[kinematics]") {
  const auto arm = arm_json();
  int checked = 0;
  for (const auto& cfg : arm.at("fk_test_values").at("configs")) {
    const auto& qj = cfg.at("q");
    const TiagoArmModel m = load_tiago_arm_model(qj.at("torso_lift_joint"));
    ArmQ q;
    for (int j = 0; j < kArmJoints; ++j) q(j) = qj.at(m.joint_names[j]);
    const ArmFkResult r = arm_fk_reference(m, q);
    const auto& frames = cfg.at("frames");
    auto check = [&](const RigidTransform& t, const std::string& name) {
      INFO(cfg.at("name").get<std::string>() << " " << name);
      CHECK((t.p - v3(frames.at(name).at("position"))).cwiseAbs().maxCoeff() < 1e-6);
      CHECK((t.R - m3(frames.at(name).at("rotation_matrix"))).cwiseAbs().maxCoeff() < 1e-6);
      ++checked;
    };
    check(r.frame[0], "arm_right_1_link");
    check(r.frame[3], "arm_right_4_link");
    check(r.frame[6], "arm_right_7_link");
    check(r.frame[kGripperFrame], "gripper_right_link");
    check(r.grasp_pal, "gripper_right_grasping_frame");
    for (int i = 0; i < kArmPoi; ++i) {
      INFO(cfg.at("name").get<std::string>() << " poi " << m.poi[i].name);
      CHECK((r.poi[i] - v3(cfg.at("poi_world").at(m.poi[i].name))).cwiseAbs().maxCoeff() < 1e-6);
    }
    // The envs' grasping frame is the fingertip PoI, with PAL's orientation.
    CHECK((r.grasp.p - r.poi[m.poi_index("fingertips")]).norm() < 1e-12);
    CHECK((r.grasp.R - r.grasp_pal.R).norm() < 1e-15);
  }
  CHECK(checked == 15);
}

TEST_CASE("arm Jacobians match central finite differences", "[kinematics]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  Rng rng(7, 0);
  const double h = 1e-6;
  for (int trial = 0; trial < 20; ++trial) {
    const ArmQ q = random_joint_q(m, rng);
    const ArmFkResult r = arm_fk_reference(m, q);
    for (int j = 0; j < kArmJoints; ++j) {
      ArmQ qp = q, qm = q;
      qp(j) += h;
      qm(j) -= h;
      const ArmFkResult rp = arm_fk_reference(m, qp), rm = arm_fk_reference(m, qm);
      for (int i = 0; i < kArmPoi; ++i) CHECK((r.J_poi[i].col(j) - (rp.poi[i] - rm.poi[i]) / (2 * h)).norm() < 1e-6);
      CHECK((r.J_grasp_pos.col(j) - (rp.grasp.p - rm.grasp.p) / (2 * h)).norm() < 1e-6);
      // Angular velocity from dR/dq R^T = [w]x.
      const Eigen::Matrix3d W = (rp.grasp.R - rm.grasp.R) / (2 * h) * r.grasp.R.transpose();
      const Eigen::Vector3d w(W(2, 1), W(0, 2), W(1, 0));
      CHECK((r.J_grasp_rot.col(j) - w).norm() < 1e-6);
    }
  }
}

TEST_CASE("batched SIMD FK equals the scalar reference", "[kinematics]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  Rng rng(11, 0);
  const int N = 21;  // not a multiple of the lane width
  std::vector<double> q(N * kArmJoints);
  for (int e = 0; e < N; ++e) {
    const ArmQ qe = random_joint_q(m, rng);
    for (int j = 0; j < kArmJoints; ++j) q[e * kArmJoints + j] = qe(j);
  }
  ArmFkBatch b;
  b.resize(N);
  arm_fk_batch(m, q.data(), b, 0, N);
  double err = 0.0;
  for (int e = 0; e < N; ++e) {
    const ArmFkResult r = arm_fk_reference(m, Eigen::Map<const ArmQ>(&q[e * kArmJoints]));
    for (int c = 0; c < 3; ++c) {
      err = std::max(err, std::abs(b.grasp_p[e * 3 + c] - r.grasp.p(c)));
      for (int k = 0; k < 3; ++k) err = std::max(err, std::abs(b.grasp_R[e * 9 + c * 3 + k] - r.grasp.R(c, k)));
      for (int j = 0; j < kArmJoints; ++j) {
        err = std::max(err, std::abs(b.J_grasp_pos[(e * 3 + c) * 7 + j] - r.J_grasp_pos(c, j)));
        err = std::max(err, std::abs(b.J_grasp_rot[(e * 3 + c) * 7 + j] - r.J_grasp_rot(c, j)));
      }
      for (int i = 0; i < kArmPoi; ++i) {
        err = std::max(err, std::abs(b.poi[(e * kArmPoi + i) * 3 + c] - r.poi[i](c)));
        for (int j = 0; j < kArmJoints; ++j)
          err = std::max(err, std::abs(b.J_poi[((e * kArmPoi + i) * 3 + c) * 7 + j] - r.J_poi[i](c, j)));
      }
    }
  }
  CHECK(err < 1e-12);
}

TEST_CASE("PoI cover radii cover every capsule part", "[kinematics]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  Rng rng(3, 0);
  // Sample capsule points and joint angles: every sampled capsule point lies
  // within scene_cover - its radius of the PoI assigned to it.
  for (const ArmCapsule& cap : m.capsules) {
    for (const CoverPart& part : cap.cover) {
      for (int s = 0; s <= 10; ++s) {
        const double t = part.t0 + (part.t1 - part.t0) * s / 10.0;
        const Eigen::Vector3d x = cap.a + t * (cap.b - cap.a);
        for (int trial = 0; trial < 50; ++trial) {
          const ArmFkResult r = arm_fk_reference(m, random_joint_q(m, rng));
          const Eigen::Vector3d xw = r.frame[cap.frame].apply(x);
          INFO(cap.name << " t=" << t << " poi " << m.poi[part.poi].name);
          CHECK((xw - r.poi[part.poi]).norm() + cap.radius <= m.scene_cover[part.poi] + 1e-12);
        }
      }
    }
  }
  for (int i = 0; i < kArmPoi; ++i) CHECK(m.scene_cover[i] >= m.poi[i].radius);
}

TEST_CASE("missing data directory gives a clear error", "[kinematics]") {
  const char* old = std::getenv("ATACOM_DATA_DIR");
  const std::string saved = old ? old : "";
  setenv("ATACOM_DATA_DIR", "/nonexistent-atacom-data", 1);
  CHECK_THROWS_WITH(load_tiago_arm_model(0.1), Catch::Contains("ATACOM_DATA_DIR"));
  if (old) setenv("ATACOM_DATA_DIR", saved.c_str(), 1); else unsetenv("ATACOM_DATA_DIR");
}

TEST_CASE("PoI spheres marked inside a capsule stay inside it", "[kinematics]") {
  const TiagoArmModel m = load_tiago_arm_model(0.1);
  Rng rng(31, 0);
  int marked = 0;
  for (const ArmPoi& p : m.poi) marked += p.inside_capsule;
  CHECK(marked >= 3);
  for (int trial = 0; trial < 500; ++trial) {
    const ArmFkResult r = arm_fk_reference(m, random_joint_q(m, rng));
    for (int i = 0; i < kArmPoi; ++i) {
      if (!m.poi[i].inside_capsule) continue;
      double best = 1e9;
      for (const ArmCapsule& cap : m.capsules) {
        const Eigen::Vector3d a = r.frame[cap.frame].apply(cap.a), b = r.frame[cap.frame].apply(cap.b), ab = b - a;
        const double t = ab.squaredNorm() > 0 ? std::clamp((r.poi[i] - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
        best = std::min(best, (r.poi[i] - (a + t * ab)).norm() + m.poi[i].radius - cap.radius);
      }
      CHECK(best <= 1e-12);
    }
  }
}
