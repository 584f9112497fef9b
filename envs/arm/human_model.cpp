#include "envs/arm/human_model.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "src/core/data_dir.hpp"

namespace atacom {

namespace {

using nlohmann::json;

json read_human_json(const std::string& name) {
  const std::string path = data_file(name);
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error("cannot parse '" + path + "': " + e.what());
  }
}

Eigen::Vector3d human_vec3(const json& j, const std::string& what) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number())
    throw std::runtime_error(what + ": expected 3 numbers");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Rotation about sign * e_axis by theta.
Eigen::Matrix3d axis_rotation(int axis, double sign, double theta) {
  return Eigen::AngleAxisd(sign * theta, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
}

Eigen::Matrix3d skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d S;
  S << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return S;
}

}  // namespace

int HumanModel::joint_index(const std::string& name) const {
  for (size_t i = 0; i < joints.size(); ++i)
    if (joints[i].name == name) return static_cast<int>(i);
  throw std::invalid_argument("unknown human joint '" + name + "'");
}

int HumanModel::capsule_index(const std::string& name) const {
  for (size_t i = 0; i < capsules.size(); ++i)
    if (capsules[i].name == name) return static_cast<int>(i);
  throw std::invalid_argument("unknown human capsule '" + name + "'");
}

int HumanModel::pose_index(const std::string& dof_name) const {
  for (size_t i = 0; i < dofs.size(); ++i)
    if (dofs[i].name == dof_name) return kHumanRootDofs + static_cast<int>(i);
  throw std::invalid_argument("unknown human degree of freedom '" + dof_name + "'");
}

std::string HumanModel::pose_name(int i) const {
  static const char* root[kHumanRootDofs] = {"x", "y", "z", "yaw"};
  if (i < 0 || i >= kHumanPoseDim) throw std::invalid_argument("human pose index out of range");
  return i < kHumanRootDofs ? root[i] : dofs[static_cast<size_t>(i - kHumanRootDofs)].name;
}

double HumanModel::lower(int i) const {
  return i < kHumanRootDofs ? -std::numeric_limits<double>::infinity() : dofs[static_cast<size_t>(i - kHumanRootDofs)].lower;
}
double HumanModel::upper(int i) const {
  return i < kHumanRootDofs ? std::numeric_limits<double>::infinity() : dofs[static_cast<size_t>(i - kHumanRootDofs)].upper;
}

HumanModel load_human_model() {
  const json sk = read_human_json("human_skeleton.json");
  const json dj = read_human_json("human_dofs.json");
  HumanModel m;
  const std::string where = "human_skeleton.json";
  try {
    m.stature = sk.at("stature").get<double>();
    for (const json& j : sk.at("joints")) {
      HumanJoint hj;
      hj.name = j.at("name").get<std::string>();
      hj.position = human_vec3(j.at("position"), where + " joint " + hj.name);
      if (!j.at("parent").is_null()) hj.parent = m.joint_index(j.at("parent").get<std::string>());
      else if (!m.joints.empty()) throw std::runtime_error(where + ": only the first joint may be the root");
      m.joints.push_back(hj);
    }
    for (const json& s : sk.at("segments")) {
      HumanCapsule c;
      c.name = s.at("name").get<std::string>();
      c.joint = m.joint_index(s.at("attached_to").get<std::string>());
      c.p0 = human_vec3(s.at("p0"), where + " segment " + c.name);
      c.p1 = human_vec3(s.at("p1"), where + " segment " + c.name);
      c.radius = s.at("radius").get<double>();
      if (!(c.radius > 0.0)) throw std::runtime_error(where + " segment " + c.name + ": radius must be > 0");
      m.capsules.push_back(c);
    }
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(where + ": " + e.what());
  } catch (const json::exception& e) {
    throw std::runtime_error(where + ": " + e.what());
  }
  if (static_cast<int>(m.joints.size()) != kHumanJoints || static_cast<int>(m.capsules.size()) != kHumanCapsules)
    throw std::runtime_error(where + ": expected " + std::to_string(kHumanJoints) + " joints and " +
                             std::to_string(kHumanCapsules) + " segments, found " + std::to_string(m.joints.size()) +
                             " and " + std::to_string(m.capsules.size()));
  const std::string dwhere = "human_dofs.json";
  try {
    int last_joint = -1;
    for (const json& d : dj.at("dofs")) {
      HumanDof hd;
      hd.name = d.at("name").get<std::string>();
      hd.joint = m.joint_index(d.at("joint").get<std::string>());
      const std::string ax = d.at("axis").get<std::string>();
      if (ax.size() != 2 || (ax[0] != '+' && ax[0] != '-') || ax[1] < 'x' || ax[1] > 'z')
        throw std::runtime_error(dwhere + " dof " + hd.name + ": axis must be one of +x -x +y -y +z -z");
      hd.sign = ax[0] == '+' ? 1.0 : -1.0;
      hd.axis = ax[1] - 'x';
      hd.lower = d.at("lower_deg").get<double>() * kDeg;
      hd.upper = d.at("upper_deg").get<double>() * kDeg;
      if (!(hd.lower <= 0.0 && 0.0 <= hd.upper))
        throw std::runtime_error(dwhere + " dof " + hd.name + ": the neutral angle 0 must lie within its limits");
      if (hd.joint < last_joint) throw std::runtime_error(dwhere + ": dofs must be grouped by joint in chain order");
      HumanJoint& j = m.joints[static_cast<size_t>(hd.joint)];
      if (hd.joint != last_joint) j.dof_begin = kHumanRootDofs + static_cast<int>(m.dofs.size());
      else if (j.dof_begin + j.dof_count != kHumanRootDofs + static_cast<int>(m.dofs.size()))
        throw std::runtime_error(dwhere + ": dofs of joint " + j.name + " must be consecutive");
      ++j.dof_count;
      last_joint = hd.joint;
      m.dofs.push_back(hd);
    }
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(dwhere + ": " + e.what());
  } catch (const json::exception& e) {
    throw std::runtime_error(dwhere + ": " + e.what());
  }
  if (static_cast<int>(m.dofs.size()) != kHumanDofs)
    throw std::runtime_error(dwhere + ": expected " + std::to_string(kHumanDofs) + " dofs, found " +
                             std::to_string(m.dofs.size()));

  // Kernel tables.
  HumanFkConst& k = m.fk;
  for (int j = 0; j < kHumanJoints; ++j) {
    const HumanJoint& hj = m.joints[static_cast<size_t>(j)];
    k.parent[j] = hj.parent;
    const Eigen::Vector3d off = hj.parent < 0 ? hj.position : Eigen::Vector3d(hj.position - m.joints[static_cast<size_t>(hj.parent)].position);
    for (int r = 0; r < 3; ++r) k.offset[j][r] = off(r);
    k.dof_begin[j] = hj.dof_count > 0 ? hj.dof_begin : kHumanRootDofs;
    k.dof_count[j] = hj.dof_count;
    k.needed[j] = 0;
  }
  for (int i = 0; i < kHumanPoseDim; ++i) {
    k.axis[i] = i == 3 ? 2 : 0;
    k.sign[i] = 1.0;
  }
  for (int d = 0; d < kHumanDofs; ++d) {
    k.axis[kHumanRootDofs + d] = m.dofs[static_cast<size_t>(d)].axis;
    k.sign[kHumanRootDofs + d] = m.dofs[static_cast<size_t>(d)].sign;
  }
  for (int c = 0; c < kHumanCapsules; ++c) {
    const HumanCapsule& hc = m.capsules[static_cast<size_t>(c)];
    k.cap_joint[c] = hc.joint;
    const Eigen::Vector3d& o = m.joints[static_cast<size_t>(hc.joint)].position;
    for (int r = 0; r < 3; ++r) {
      k.cap_a[c][r] = hc.p0(r) - o(r);
      k.cap_b[c][r] = hc.p1(r) - o(r);
    }
    k.cap_radius[c] = hc.radius;
    const double l2 = (hc.p1 - hc.p0).squaredNorm();
    k.cap_inv_len2[c] = l2 > 0.0 ? 1.0 / l2 : 0.0;
    for (int j = hc.joint; j >= 0; j = k.parent[j]) k.needed[j] = 1;
  }
  return m;
}

HumanFkResult human_fk_reference(const HumanModel& m, const double* pose, const double* rate) {
  HumanFkResult r;
  r.R.resize(kHumanJoints);
  r.R_dot.resize(kHumanJoints);
  r.p.resize(kHumanJoints);
  r.p_dot.resize(kHumanJoints);
  // World angular velocity w_j rides along: R_dot = [w]x R.
  std::vector<Eigen::Vector3d> w(kHumanJoints);
  auto qd = [&](int i) { return rate ? rate[i] : 0.0; };
  for (int j = 0; j < kHumanJoints; ++j) {
    const HumanJoint& hj = m.joints[static_cast<size_t>(j)];
    Eigen::Matrix3d R;
    Eigen::Vector3d p, v, om;
    if (hj.parent < 0) {
      R = Eigen::AngleAxisd(pose[3], Eigen::Vector3d::UnitZ()).toRotationMatrix();
      om = Eigen::Vector3d(0, 0, qd(3));
      p = Eigen::Vector3d(pose[0], pose[1], pose[2]) + R * hj.position;
      v = Eigen::Vector3d(qd(0), qd(1), qd(2)) + om.cross(R * hj.position);
    } else {
      const size_t P = static_cast<size_t>(hj.parent);
      const Eigen::Vector3d off = hj.position - m.joints[P].position;
      R = r.R[P];
      om = w[P];
      p = r.p[P] + R * off;
      v = r.p_dot[P] + om.cross(R * off);
    }
    for (int d = 0; d < hj.dof_count; ++d) {
      const int i = hj.dof_begin + d;
      const HumanDof& hd = m.dofs[static_cast<size_t>(i - kHumanRootDofs)];
      // The rotation axis in world coordinates is the current frame's axis.
      om += R.col(hd.axis) * (hd.sign * qd(i));
      R = R * axis_rotation(hd.axis, hd.sign, pose[i]);
    }
    r.R[static_cast<size_t>(j)] = R;
    r.R_dot[static_cast<size_t>(j)] = skew(om) * R;
    r.p[static_cast<size_t>(j)] = p;
    r.p_dot[static_cast<size_t>(j)] = v;
    w[static_cast<size_t>(j)] = om;
  }
  for (const HumanCapsule& c : m.capsules) {
    const size_t j = static_cast<size_t>(c.joint);
    const Eigen::Vector3d o = m.joints[j].position;
    const Eigen::Vector3d la = r.R[j] * (c.p0 - o), lb = r.R[j] * (c.p1 - o);
    r.a.push_back(r.p[j] + la);
    r.b.push_back(r.p[j] + lb);
    r.va.push_back(r.p_dot[j] + w[j].cross(la));
    r.vb.push_back(r.p_dot[j] + w[j].cross(lb));
  }
  return r;
}

}  // namespace atacom
