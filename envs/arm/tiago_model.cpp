#include "envs/arm/tiago_model.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/data_dir.hpp"

namespace atacom {

namespace {

using nlohmann::json;

json read_json(const std::string& name) {
  const std::string path = data_file(name);
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error("cannot parse '" + path + "': " + e.what());
  }
}

Eigen::Vector3d vec3(const json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 3) throw std::runtime_error(what + ": expected 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// Frame index of a link name: 0..6 arm links, 7 gripper.
int frame_of(const std::string& link) {
  for (int i = 0; i < kArmJoints; ++i)
    if (link == "arm_right_" + std::to_string(i + 1) + "_link") return i;
  if (link == "gripper_right_link") return kGripperFrame;
  throw std::runtime_error("unknown link '" + link + "' (expected arm_right_1..7_link or gripper_right_link)");
}

// Rigid body of a frame: the gripper is rigid with arm_right_7_link.
int body_of(int frame) { return frame == kGripperFrame ? kArmJoints - 1 : frame; }

Eigen::Vector3d to_body(const TiagoArmModel& m, int frame, const Eigen::Vector3d& v) {
  return frame == kGripperFrame ? m.gripper_in_link7.apply(v) : v;
}

// Max distance from s to a point on the circle {o + Rot(axis, q) (v - o)}:
// sqrt((rho_s + rho_v)^2 + (h_s - h_v)^2) in cylinder coordinates.
double circle_max_distance(const Eigen::Vector3d& s, const Eigen::Vector3d& v, const Eigen::Vector3d& o,
                           const Eigen::Vector3d& axis) {
  const Eigen::Vector3d ds = s - o, dv = v - o;
  const double hs = ds.dot(axis), hv = dv.dot(axis);
  const double rs = (ds - hs * axis).norm(), rv = (dv - hv * axis).norm();
  return std::hypot(rs + rv, hs - hv);
}

}  // namespace

RigidTransform urdf_origin(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
  RigidTransform t;
  t.R = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
  t.p = xyz;
  return t;
}

int TiagoArmModel::poi_index(const std::string& name) const {
  for (int i = 0; i < kArmPoi; ++i)
    if (poi[i].name == name) return i;
  throw std::invalid_argument("unknown point of interest '" + name + "'");
}

double cover_distance(const TiagoArmModel& m, const ArmCapsule& cap, const Eigen::Vector3d& s_frame, int poi) {
  const ArmPoi& p = m.poi.at(poi);
  const int bc = body_of(cap.frame), bp = body_of(p.frame);
  const Eigen::Vector3d s = to_body(m, cap.frame, s_frame);
  const Eigen::Vector3d v = to_body(m, p.frame, p.offset);
  if (bp == bc) return (s - v).norm();
  if (bp == bc + 1) {
    // PoI on the child body: it turns about the child joint's axis.
    const RigidTransform& o = m.joint_origin[bp];
    return circle_max_distance(s, o.apply(v), o.p, o.R.col(2));
  }
  if (bp + 1 == bc) {
    // PoI on the parent body: seen from the capsule's body it turns about the
    // capsule body's own joint axis (z through its origin).
    const RigidTransform inv = m.joint_origin[bc].inverse();
    return circle_max_distance(s, inv.apply(v), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  }
  throw std::runtime_error("capsule '" + cap.name + "' cannot be covered by PoI '" + p.name +
                           "': it must sit on the same link or one joint away");
}

TiagoArmModel load_tiago_arm_model(double torso_lift) {
  const json arm = read_json("tiago_arm.json");
  const json col = read_json("tiago_collision.json");
  TiagoArmModel m;
  m.torso_lift = torso_lift;
  try {
    // Chain: fold fixed joints into the next revolute joint's origin.
    RigidTransform acc;
    int next_joint = 0;
    bool have_gripper = false, have_grasp = false;
    for (const json& j : arm.at("joints")) {
      const std::string name = j.at("name");
      const std::string type = j.at("type");
      const RigidTransform origin = urdf_origin(vec3(j.at("origin_xyz"), name), vec3(j.at("origin_rpy"), name));
      if (type == "prismatic") {
        if (name != "torso_lift_joint") throw std::runtime_error("unexpected prismatic joint '" + name + "'");
        const double lo = j.at("lower"), hi = j.at("upper");
        if (!(torso_lift >= lo && torso_lift <= hi))
          throw std::runtime_error("torso_lift " + std::to_string(torso_lift) + " outside [" + std::to_string(lo) +
                                   ", " + std::to_string(hi) + "]");
        RigidTransform lift;
        lift.p = vec3(j.at("axis"), name) * torso_lift;
        acc = acc * origin * lift;
      } else if (type == "revolute") {
        if (next_joint >= kArmJoints) throw std::runtime_error("more than 7 revolute joints");
        if (vec3(j.at("axis"), name) != Eigen::Vector3d::UnitZ())
          throw std::runtime_error("joint '" + name + "': only z axes are supported");
        m.joint_names[next_joint] = name;
        m.lower[next_joint] = j.at("lower");
        m.upper[next_joint] = j.at("upper");
        m.velocity[next_joint] = j.at("velocity");
        m.joint_origin[next_joint] = acc * origin;
        acc = RigidTransform{};
        ++next_joint;
      } else if (type == "fixed") {
        if (name == "gripper_right_joint") {
          m.gripper_in_link7 = acc * origin;
          acc = RigidTransform{};
          have_gripper = true;
        } else if (name == "gripper_right_grasping_frame_joint") {
          m.grasp_pal_in_gripper = origin;
          have_grasp = true;
        } else {
          acc = acc * origin;
        }
      } else {
        throw std::runtime_error("joint '" + name + "' has unsupported type '" + type + "'");
      }
    }
    if (next_joint != kArmJoints || !have_gripper || !have_grasp)
      throw std::runtime_error("chain must have 7 revolute joints, gripper_right_joint and the grasping frame");
    bool have_tip = false;
    for (const json& f : arm.at("additional_frames")) {
      if (f.at("parent") == "gripper_right_link" && std::string(f.at("name")).rfind("fingertip", 0) == 0) {
        m.grasp_in_gripper = urdf_origin(vec3(f.at("origin_xyz"), "fingertip"), vec3(f.at("origin_rpy"), "fingertip"));
        have_tip = true;
      }
    }
    if (!have_tip) throw std::runtime_error("additional frame 'fingertip_center' missing");

    const json& plist = arm.at("points_of_interest").at("list");
    if (plist.size() != kArmPoi) throw std::runtime_error("expected 9 points of interest");
    const json& pbody = col.at("poi_body_check");
    for (int i = 0; i < kArmPoi; ++i) {
      ArmPoi& p = m.poi[i];
      p.name = plist[i].at("name");
      p.frame = frame_of(plist[i].at("link"));
      p.offset = vec3(plist[i].at("offset"), p.name);
      p.radius = plist[i].at("radius");
      p.body_check = pbody.contains(p.name) ? pbody.at(p.name).get<bool>() : true;
    }
    for (const json& c : col.at("link_capsules")) {
      ArmCapsule cap;
      cap.name = c.at("name");
      cap.frame = frame_of(c.at("link"));
      cap.a = vec3(c.at("a"), cap.name);
      cap.b = vec3(c.at("b"), cap.name);
      cap.radius = c.at("radius");
      cap.body_check = c.at("body_check");
      for (const json& part : c.at("cover"))
        cap.cover.push_back({m.poi_index(part.at("poi")), part.at("t")[0].get<double>(), part.at("t")[1].get<double>()});
      m.capsules.push_back(cap);
    }
    const json& body = col.at("body");
    // torso_lift_link height: base_footprint_joint + torso_fixed_joint + torso_lift origin + torso.
    double lift = torso_lift;
    for (const json& j : arm.at("joints")) {
      const std::string name = j.at("name");
      if (name == "base_footprint_joint" || name == "torso_fixed_joint" || name == "torso_lift_joint")
        lift += j.at("origin_xyz")[2].get<double>();
    }
    const json& b = body.at("base");
    m.body.base_center = {b.at("center_xy")[0].get<double>(), b.at("center_xy")[1].get<double>()};
    m.body.base_z0 = b.at("z")[0];
    m.body.base_z1 = b.at("z")[1];
    m.body.base_radius = b.at("radius");
    const json& t = body.at("torso");
    const double z0 = t.at("z_bottom"), z1 = lift + t.at("top_above_lift").get<double>();
    m.body.torso_center = {t.at("center_xy")[0].get<double>(), t.at("center_xy")[1].get<double>(), 0.5 * (z0 + z1)};
    m.body.torso_half = {t.at("half_xy")[0].get<double>(), t.at("half_xy")[1].get<double>(), 0.5 * (z1 - z0)};
    const json& h = body.at("head");
    m.body.head_center = {h.at("center_xy")[0].get<double>(), h.at("center_xy")[1].get<double>(),
                          lift + h.at("above_lift").get<double>()};
    m.body.head_radius = h.at("radius");
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(std::string("robot data: ") + e.what());
  }

  // Cover radii: each capsule's parts must tile [0, 1]; the radius a PoI
  // needs is the farthest point of its parts (convex in t, so an end point)
  // plus the capsule radius.
  for (int i = 0; i < kArmPoi; ++i) {
    m.scene_cover[i] = m.poi[i].radius;
    m.body_cover[i] = m.poi[i].body_check ? m.poi[i].radius : 0.0;
  }
  for (const ArmCapsule& cap : m.capsules) {
    std::vector<CoverPart> parts = cap.cover;
    std::sort(parts.begin(), parts.end(), [](const CoverPart& x, const CoverPart& y) { return x.t0 < y.t0; });
    double reached = 0.0;
    for (const CoverPart& part : parts) {
      if (part.t0 > reached + 1e-12 || part.t1 < part.t0)
        throw std::runtime_error("capsule '" + cap.name + "': cover parts must tile [0, 1] without gaps");
      reached = std::max(reached, part.t1);
      double need = 0.0;
      for (double t : {part.t0, part.t1})
        need = std::max(need, cover_distance(m, cap, cap.a + t * (cap.b - cap.a), part.poi));
      need += cap.radius;
      m.scene_cover[part.poi] = std::max(m.scene_cover[part.poi], need);
      if (cap.body_check) m.body_cover[part.poi] = std::max(m.body_cover[part.poi], need);
    }
    if (reached < 1.0 - 1e-12) throw std::runtime_error("capsule '" + cap.name + "': cover parts end before t = 1");
  }

  // PoI spheres that stay inside one capsule whatever q is: the PoI is on the
  // capsule's body, or on the axis of the joint next to it (so it does not
  // move relative to that body).
  for (ArmPoi& p : m.poi) {
    for (const ArmCapsule& cap : m.capsules) {
      const int bc = body_of(cap.frame), bp = body_of(p.frame);
      const Eigen::Vector3d v = to_body(m, p.frame, p.offset);
      Eigen::Vector3d c;
      if (bp == bc) {
        c = v;
      } else if (bp == bc + 1 && v.head<2>().norm() < 1e-12) {
        c = m.joint_origin[bp].apply(v);
      } else if (bp + 1 == bc && m.joint_origin[bc].inverse().apply(v).head<2>().norm() < 1e-12) {
        c = m.joint_origin[bc].inverse().apply(v);
      } else {
        continue;
      }
      const Eigen::Vector3d a = to_body(m, cap.frame, cap.a), b = to_body(m, cap.frame, cap.b), ab = b - a;
      const double t = ab.squaredNorm() > 0.0 ? std::clamp((c - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      if ((c - (a + t * ab)).norm() + p.radius <= cap.radius && (cap.body_check || !p.body_check)) p.inside_capsule = true;
    }
  }

  m.shoulder = m.joint_origin[0].p;
  // Reach bound: sum of joint-to-joint offsets plus the farthest gripper point.
  double reach = 0.0;
  for (int i = 1; i < kArmJoints; ++i) reach += m.joint_origin[i].p.norm();
  double tip = m.gripper_in_link7.p.norm() + m.grasp_in_gripper.p.norm();
  for (const ArmCapsule& cap : m.capsules)
    if (cap.frame == kGripperFrame)
      tip = std::max(tip, m.gripper_in_link7.p.norm() + std::max(cap.a.norm(), cap.b.norm()) + cap.radius);
  m.reach = reach + tip;
  return m;
}

}  // namespace atacom
