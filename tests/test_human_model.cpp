// The capsule human's kinematics: the neutral pose reproduces the skeleton
// file, the sign conventions move limbs the documented way, the reference FK
// agrees with an independent per-capsule computation (quaternions, read
// straight from the JSON), the lane kernel agrees with the reference, and
// every capsule velocity is the time derivative of its position.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <map>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "envs/arm/human_model.hpp"
#include "kernels/human_kernels.hpp"
#include "src/core/data_dir.hpp"
#include "tests/loaded_human.hpp"

using namespace atacom;
using Eigen::Vector3d;

namespace {

// A random pose inside the joint limits, root anywhere near the table.
HumanPose random_pose(Rng& rng) {
  const HumanModel& m = human_model();
  HumanPose p{};
  p[0] = rng.uniform(0.5, 2.0);
  p[1] = rng.uniform(-1.0, 1.0);
  p[2] = rng.uniform(-0.05, 0.02);
  p[3] = rng.uniform(-10.0, 10.0);
  for (int i = kHumanRootDofs; i < kHumanPoseDim; ++i) p[i] = rng.uniform(m.lower(i), m.upper(i));
  return p;
}

HumanPose random_rate(Rng& rng) {
  HumanPose r{};
  for (int i = 0; i < kHumanPoseDim; ++i) r[i] = rng.uniform(-2.0, 2.0);
  return r;
}

// Independent FK of one capsule: chain from the JSON's own joint table,
// orientation as quaternions, walked from the root down to the capsule.
std::pair<Vector3d, Vector3d> capsule_by_chain(const nlohmann::json& sk, const nlohmann::json& dj,
                                               const std::string& segment, const HumanPose& pose) {
  std::map<std::string, nlohmann::json> joints;
  for (const auto& j : sk["joints"]) joints[j["name"].get<std::string>()] = j;
  nlohmann::json seg;
  for (const auto& s : sk["segments"])
    if (s["name"] == segment) seg = s;
  std::vector<std::string> chain;
  for (std::string j = seg["attached_to"]; ; ) {
    chain.insert(chain.begin(), j);
    if (joints[j]["parent"].is_null()) break;
    j = joints[j]["parent"].get<std::string>();
  }
  auto pos = [&](const std::string& j) {
    const auto& a = joints[j]["position"];
    return Vector3d(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  Eigen::Quaterniond q(Eigen::AngleAxisd(pose[3], Vector3d::UnitZ()));
  Vector3d o = Vector3d(pose[0], pose[1], pose[2]) + q * pos(chain[0]);
  for (size_t c = 0; c < chain.size(); ++c) {
    if (c > 0) o += q * (pos(chain[c]) - pos(chain[c - 1]));
    int k = kHumanRootDofs;
    for (const auto& d : dj["dofs"]) {
      if (d["joint"] == chain[c]) {
        const std::string ax = d["axis"];
        Vector3d axis = Vector3d::Zero();
        axis(ax[1] - 'x') = ax[0] == '+' ? 1.0 : -1.0;
        q = q * Eigen::Quaterniond(Eigen::AngleAxisd(pose[static_cast<size_t>(k)], axis));
      }
      ++k;
    }
  }
  auto pt = [&](const char* key) {
    const auto& a = seg[key];
    return Vector3d(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  return {o + q * (pt("p0") - pos(chain.back())), o + q * (pt("p1") - pos(chain.back()))};
}

nlohmann::json read(const std::string& name) {
  std::ifstream in(data_file(name));
  return nlohmann::json::parse(in);
}

}  // namespace

TEST_CASE("human model loads the skeleton: 20 joints, 16 capsules, 34 angles", "[human]") {
  const HumanModel& m = human_model();
  REQUIRE(m.joints.size() == 20);
  REQUIRE(m.capsules.size() == 16);
  REQUIRE(m.dofs.size() == 34);
  CHECK(m.stature == Approx(1.75));
  CHECK(m.capsules[static_cast<size_t>(m.capsule_index("thigh_l"))].radius == Approx(0.0992));
  CHECK(m.pose_name(3) == "yaw");
  CHECK(m.pose_index("knee_r_flexion") == kHumanPoseDim - 1);
  CHECK_THROWS_AS(m.pose_index("tail_wag"), std::invalid_argument);
  for (int i = kHumanRootDofs; i < kHumanPoseDim; ++i) CHECK(m.lower(i) < m.upper(i));
}

TEST_CASE("human neutral pose reproduces the skeleton file, root pose moves it rigidly", "[human]") {
  const HumanModel& m = human_model();
  HumanPose p{};
  HumanFkResult fk = human_fk_reference(m, p.data());
  for (int c = 0; c < kHumanCapsules; ++c) {
    CHECK((fk.a[static_cast<size_t>(c)] - m.capsules[static_cast<size_t>(c)].p0).norm() < 1e-12);
    CHECK((fk.b[static_cast<size_t>(c)] - m.capsules[static_cast<size_t>(c)].p1).norm() < 1e-12);
  }
  p[0] = 1.5;
  p[1] = -0.2;
  p[2] = 0.01;
  p[3] = 3.14159265358979323846;  // facing -x (towards the robot)
  fk = human_fk_reference(m, p.data());
  const int hl = m.capsule_index("hand_l");
  const Vector3d n = m.capsules[static_cast<size_t>(hl)].p1;
  CHECK((fk.b[static_cast<size_t>(hl)] - Vector3d(1.5 - n.x(), -0.2 - n.y(), 0.01 + n.z())).norm() < 1e-12);
}

TEST_CASE("human angle signs: flexion forward, abduction outward, knee backward, lean forward", "[human]") {
  const HumanModel& m = human_model();
  const double h = 1.5707963267948966;
  auto tip_of = [&](const char* dof, double angle, const char* capsule) {
    HumanPose p{};
    p[static_cast<size_t>(m.pose_index(dof))] = angle;
    const HumanFkResult fk = human_fk_reference(m, p.data());
    const size_t c = static_cast<size_t>(m.capsule_index(capsule));
    return Vector3d(fk.b[c] - fk.a[c]);
  };
  CHECK((tip_of("shoulder_l_flexion", h, "upper_arm_l").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("shoulder_r_flexion", h, "upper_arm_r").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("shoulder_l_abduction", h, "upper_arm_l").normalized() - Vector3d(0, 1, 0)).norm() < 1e-12);
  CHECK((tip_of("shoulder_r_abduction", h, "upper_arm_r").normalized() - Vector3d(0, -1, 0)).norm() < 1e-12);
  CHECK((tip_of("hip_l_flexion", h, "thigh_l").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("knee_r_flexion", h, "shin_r").normalized() - Vector3d(-1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("elbow_l_flexion", h, "forearm_l").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("lumbar_flexion", h, "spine").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK((tip_of("lumbar_lateral", h, "spine").normalized() - Vector3d(0, 1, 0)).norm() < 1e-12);
  CHECK((tip_of("neck_flexion", h, "neck").normalized() - Vector3d(1, 0, 0)).norm() < 1e-12);
  // Internal rotation of the left arm turns a bent forearm towards the midline (-y).
  HumanPose p{};
  p[static_cast<size_t>(m.pose_index("elbow_l_flexion"))] = h;
  p[static_cast<size_t>(m.pose_index("shoulder_l_rotation"))] = h;
  const HumanFkResult fk = human_fk_reference(m, p.data());
  const size_t fa = static_cast<size_t>(m.capsule_index("forearm_l"));
  CHECK(((fk.b[fa] - fk.a[fa]).normalized() - Vector3d(0, -1, 0)).norm() < 1e-12);
}

TEST_CASE("human reference FK matches an independent per-capsule chain", "[human]") {
  const HumanModel& m = human_model();
  const nlohmann::json sk = read("human_skeleton.json"), dj = read("human_dofs.json");
  Rng rng(7, 0);
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const HumanPose p = random_pose(rng);
    const HumanFkResult fk = human_fk_reference(m, p.data());
    for (int c = 0; c < kHumanCapsules; ++c) {
      const auto [a, b] = capsule_by_chain(sk, dj, m.capsules[static_cast<size_t>(c)].name, p);
      worst = std::max({worst, (a - fk.a[static_cast<size_t>(c)]).norm(), (b - fk.b[static_cast<size_t>(c)]).norm()});
    }
  }
  CHECK(worst < 1e-12);
}

TEST_CASE("human capsule velocities are the time derivatives of the positions", "[human]") {
  const HumanModel& m = human_model();
  Rng rng(8, 0);
  const double h = 1e-6;
  double worst = 0;
  for (int trial = 0; trial < 20; ++trial) {
    const HumanPose p = random_pose(rng), r = random_rate(rng);
    HumanPose pp = p, pm = p;
    for (int i = 0; i < kHumanPoseDim; ++i) {
      pp[i] += h * r[i];
      pm[i] -= h * r[i];
    }
    const HumanFkResult f0 = human_fk_reference(m, p.data(), r.data());
    const HumanFkResult fp = human_fk_reference(m, pp.data()), fm = human_fk_reference(m, pm.data());
    for (size_t c = 0; c < kHumanCapsules; ++c) {
      worst = std::max(worst, ((fp.a[c] - fm.a[c]) / (2 * h) - f0.va[c]).norm());
      worst = std::max(worst, ((fp.b[c] - fm.b[c]) / (2 * h) - f0.vb[c]).norm());
    }
    for (size_t j = 0; j < kHumanJoints; ++j)
      worst = std::max(worst, ((fp.R[j] - fm.R[j]) / (2 * h) - f0.R_dot[j]).norm());
  }
  CHECK(worst < 1e-6);
}

TEST_CASE("human capsule lane kernel matches the reference FK for every env of a range", "[human]") {
  const HumanModel& m = human_model();
  Rng rng(9, 0);
  const int N = 21;  // two full lane blocks and a partial one
  HumanBatch B(N);
  for (int e = 0; e < N; ++e) {
    const HumanPose p = random_pose(rng), r = random_rate(rng);
    std::copy(p.begin(), p.end(), &B.pose[static_cast<size_t>(e) * kHumanPoseDim]);
    std::copy(r.begin(), r.end(), &B.pose_rate[static_cast<size_t>(e) * kHumanPoseDim]);
  }
  human_capsules_range(m.fk, B, 3, N);  // env 0..2 stay untouched
  double worst = 0;
  for (int e = 0; e < N; ++e) {
    const HumanFkResult fk =
        human_fk_reference(m, &B.pose[static_cast<size_t>(e) * kHumanPoseDim], &B.pose_rate[static_cast<size_t>(e) * kHumanPoseDim]);
    for (int c = 0; c < kHumanCapsules; ++c) {
      const double* cap = &B.cap[(static_cast<size_t>(e) * kHumanCapsules + c) * 6];
      const double* vel = &B.cap_vel[(static_cast<size_t>(e) * kHumanCapsules + c) * 6];
      const size_t sc = static_cast<size_t>(c);
      if (e < 3) {
        CHECK(cap[0] == 0.0);
        CHECK(vel[5] == 0.0);
        continue;
      }
      worst = std::max({worst, (Eigen::Map<const Vector3d>(cap) - fk.a[sc]).norm(),
                        (Eigen::Map<const Vector3d>(cap + 3) - fk.b[sc]).norm(),
                        (Eigen::Map<const Vector3d>(vel) - fk.va[sc]).norm(),
                        (Eigen::Map<const Vector3d>(vel + 3) - fk.vb[sc]).norm()});
    }
  }
  CHECK(worst < 1e-12);
}
