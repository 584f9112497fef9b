// Closed-loop test scenarios: one per control-affine system of the core,
// each with joint/steering/velocity limits, nonlinear Cartesian constraints
// and a smoothly moving circular obstacle whose velocity is known.
#pragma once
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "atacom/system.hpp"

namespace atacom::test {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

// Obstacle on a Lissajous path: position, velocity and acceleration at t.
struct MovingDisc {
  Eigen::Vector2d center{0, 0}, amp{0.3, 0.3};
  double wx = 0.5, wy = 0.7, radius = 0.15;
  Eigen::Vector2d pos(double t) const { return center + Eigen::Vector2d(amp.x() * std::cos(wx * t), amp.y() * std::sin(wy * t)); }
  Eigen::Vector2d vel(double t) const { return Eigen::Vector2d(-amp.x() * wx * std::sin(wx * t), amp.y() * wy * std::cos(wy * t)); }
  Eigen::Vector2d acc(double t) const { return Eigen::Vector2d(-amp.x() * wx * wx * std::cos(wx * t), -amp.y() * wy * wy * std::sin(wy * t)); }
};

// Everything the projector needs for one state, plus the true constraint values.
struct Eval {
  Vec f, c, xdot;
  Mat G, Jq, Jx;
};

struct Scenario {
  std::string name;
  ProjectorModel model;
  double dt = 1.0 / 30.0;
  virtual ~Scenario() = default;
  virtual int n() const = 0;
  virtual Eval eval(const Vec& q, double t) const = 0;
  // Euler step of qdot = f + G a (the scenarios integrate exactly what the
  // projector models). Like every env, the actuator saturates: a is clipped
  // to [-1, 1]^m (the projector's a leaves the box only when its correction
  // term alone does, and says so in its status).
  virtual void integrate(Vec& q, const Vec& a, double t) const {
    const Eval e = eval(q, t);
    q += dt * (e.f + e.G * a.cwiseMax(-1.0).cwiseMin(1.0));
  }
  // Sample a state strictly inside the safe set (every row <= -margin).
  Vec sample_start(Rng& rng, double t, double margin = 0.02) const {
    for (int tries = 0; tries < 100000; ++tries) {
      Vec q = sample_raw(rng);
      if (eval(q, t).c.maxCoeff() <= -margin) return q;
    }
    return sample_raw(rng);
  }
  virtual Vec sample_raw(Rng& rng) const = 0;
};

// Rows for a wheeled robot whose look-ahead point pd (Jacobian Jd, 2 x n)
// must keep `reach` from the walls of [-half_w, half_w] x [-half_h, half_h]
// and from the moving disc: 4 wall rows then 1 disc row, from row `first`.
inline void lookahead_rows(const Eigen::Vector2d& pd, const Mat& Jd, double reach, double half_w, double half_h,
                           const MovingDisc& obs, double t, Eval& e, int first) {
  e.c(first + 0) = pd.x() + reach - half_w;  e.Jq.row(first + 0) = Jd.row(0);
  e.c(first + 1) = -half_w - pd.x() + reach; e.Jq.row(first + 1) = -Jd.row(0);
  e.c(first + 2) = pd.y() + reach - half_h;  e.Jq.row(first + 2) = Jd.row(1);
  e.c(first + 3) = -half_h - pd.y() + reach; e.Jq.row(first + 3) = -Jd.row(1);
  const Eigen::Vector2d diff = pd - obs.pos(t);
  const double dist = diff.norm();
  const Eigen::Vector2d u = diff / dist;
  e.c(first + 4) = obs.radius + reach - dist;
  e.Jq.row(first + 4) = -u.transpose() * Jd;
  e.Jx.row(first + 4) = u.transpose();
  e.xdot = obs.vel(t);
}

// ---- A: planar 3-link arm, velocity control -------------------------------
// Rows: 6 joint limits, 3 floor rows (elbow, wrist, tip above y = -0.3),
// 2 obstacle rows (wrist, tip clear of the moving disc by 0.05 m).
struct ArmScenario : Scenario {
  VelocityArmSystem sys{{1.0, 1.2, 1.5}};
  double l[3] = {0.5, 0.4, 0.3};
  double qmax = 2.5, floor_y = -0.3, margin = 0.05;
  MovingDisc obs{{0.55, 0.55}, {0.25, 0.15}, 0.5, 0.7, 0.12};
  ArmScenario() {
    name = "arm";
    model = default_projector_model(3, 3, 11, 2);
    for (int i = 0; i < 6; ++i) model.beta[i] = 30.0;
    for (int i = 6; i < 11; ++i) model.beta[i] = 10.0;
    model.g_form = GForm::Dense;
    model.has_drift = false;
  }
  int n() const override { return 3; }
  // Points 1..3 (elbow, wrist, tip) and their 2 x 3 Jacobians.
  void points(const Vec& q, Eigen::Vector2d p[3], Eigen::Matrix<double, 2, 3> J[3]) const {
    double th = 0;
    Eigen::Vector2d acc(0, 0);
    double ths[3];
    for (int i = 0; i < 3; ++i) {
      th += q(i);
      ths[i] = th;
      acc += l[i] * Eigen::Vector2d(std::cos(th), std::sin(th));
      p[i] = acc;
    }
    for (int i = 0; i < 3; ++i) {
      J[i].setZero();
      for (int j = 0; j <= i; ++j)  // joint j moves every link from j on
        for (int s = j; s <= i; ++s) J[i].col(j) += l[s] * Eigen::Vector2d(-std::sin(ths[s]), std::cos(ths[s]));
    }
  }
  Eval eval(const Vec& q, double t) const override {
    Eval e;
    e.f = Vec::Zero(3);
    e.G = Mat::Zero(3, 3);
    sys.eval(q.data(), e.f.data(), e.G.data());
    e.c.resize(11);
    e.Jq = Mat::Zero(11, 3);
    e.Jx = Mat::Zero(11, 2);
    for (int i = 0; i < 3; ++i) {
      e.c(2 * i) = q(i) - qmax;
      e.Jq(2 * i, i) = 1;
      e.c(2 * i + 1) = -qmax - q(i);
      e.Jq(2 * i + 1, i) = -1;
    }
    Eigen::Vector2d p[3];
    Eigen::Matrix<double, 2, 3> J[3];
    points(q, p, J);
    for (int i = 0; i < 3; ++i) {
      e.c(6 + i) = floor_y - p[i].y();
      e.Jq.row(6 + i) = -J[i].row(1);
    }
    const Eigen::Vector2d o = obs.pos(t);
    for (int r = 0; r < 2; ++r) {
      const Eigen::Vector2d d = p[1 + r] - o;
      const double dist = d.norm();
      const Eigen::Vector2d u = d / dist;
      e.c(9 + r) = obs.radius + margin - dist;
      e.Jq.row(9 + r) = -u.transpose() * J[1 + r];
      e.Jx.row(9 + r) = u.transpose();
    }
    e.xdot = obs.vel(t);
    return e;
  }
  Vec sample_raw(Rng& rng) const override {
    Vec q(3);
    for (int i = 0; i < 3; ++i) q(i) = rng.uniform(-qmax, qmax);
    return q;
  }
};

// ---- B: differential drive -------------------------------------------------
// Constraints on the look-ahead point p_d = p + d h(theta): its map from
// (v, omega) is full rank, so walls and the obstacle are reachable in every
// heading; a disc of radius R + d around p_d covers the robot's disc R.
// Rows: 4 walls of the room [-2, 2] x [-1.5, 1.5], 1 obstacle clearance.
struct DiffDriveScenario : Scenario {
  DiffDriveSystem sys{1.0, M_PI / 3.0};
  double R = 0.2, d = 0.1, half_w = 2.0, half_h = 1.5, margin = 0.05;
  // The disc never comes closer than 0.85 m to a wall, more than the robot's
  // 2 x 0.35 m, so it cannot pin the robot against a wall.
  MovingDisc obs{{0.0, 0.0}, {0.8, 0.4}, 0.25, 0.35, 0.25};
  DiffDriveScenario() {
    name = "diff_drive";
    model = default_projector_model(3, 2, 5, 2);
    for (int i = 0; i < 5; ++i) model.beta[i] = 5.0;
    model.has_drift = false;
  }
  int n() const override { return 3; }
  Eval eval(const Vec& q, double t) const override {
    Eval e;
    e.f = Vec::Zero(3);
    e.G = Mat::Zero(3, 2);
    Eigen::Matrix<double, 3, 2, Eigen::RowMajor> Gr;
    sys.eval(q.data(), e.f.data(), Gr.data());
    e.G = Gr;
    const double c = std::cos(q(2)), s = std::sin(q(2));
    const Eigen::Vector2d pd(q(0) + d * c, q(1) + d * s);
    Mat Jd(2, 3);
    Jd << 1, 0, -d * s, 0, 1, d * c;
    e.c.resize(5);
    e.Jq = Mat::Zero(5, 3);
    e.Jx = Mat::Zero(5, 2);
    lookahead_rows(pd, Jd, R + d + margin, half_w, half_h, obs, t, e, 0);
    return e;
  }
  Vec sample_raw(Rng& rng) const override {
    Vec q(3);
    q << rng.uniform(-half_w, half_w), rng.uniform(-half_h, half_h), rng.uniform(-M_PI, M_PI);
    return q;
  }
};

// ---- C: kinematic bicycle ----------------------------------------------------
// q = [x, y, theta, delta]. The position responds to the speed only, so the
// constraints sit on the look-ahead point as for the diff drive, and the
// steering angle has its limits. Rows: 2 steering, 4 walls, 1 obstacle.
struct BicycleScenario : Scenario {
  BicycleSystem sys{0.4, 1.0, 1.0};
  double R = 0.2, d = 0.1, half_w = 2.5, half_h = 2.0, margin = 0.05, steer_max = 0.6;
  // A car cannot slide sideways: the disc stays >= 1.25 m from every wall
  // (room to turn away) and moves at <= 0.15 m/s.
  MovingDisc obs{{0.0, 0.0}, {0.75, 0.5}, 0.2, 0.2, 0.25};
  explicit BicycleScenario(bool moving = true) {
    name = moving ? "bicycle" : "bicycle_static_disc";
    if (!moving) obs.amp.setZero();
    model = default_projector_model(4, 2, 7, 2);
    model.beta[0] = model.beta[1] = 10.0;
    for (int i = 2; i < 7; ++i) model.beta[i] = 5.0;
    model.has_drift = false;
  }
  int n() const override { return 4; }
  Eval eval(const Vec& q, double t) const override {
    Eval e;
    e.f = Vec::Zero(4);
    Eigen::Matrix<double, 4, 2, Eigen::RowMajor> Gr;
    sys.eval(q.data(), e.f.data(), Gr.data());
    e.G = Gr;
    const double c = std::cos(q(2)), s = std::sin(q(2));
    const Eigen::Vector2d pd(q(0) + d * c, q(1) + d * s);
    Mat Jd(2, 4);
    Jd << 1, 0, -d * s, 0, 0, 1, d * c, 0;
    e.c.resize(7);
    e.Jq = Mat::Zero(7, 4);
    e.Jx = Mat::Zero(7, 2);
    e.c(0) = q(3) - steer_max; e.Jq(0, 3) = 1;
    e.c(1) = -steer_max - q(3); e.Jq(1, 3) = -1;
    lookahead_rows(pd, Jd, R + d + margin, half_w, half_h, obs, t, e, 2);
    return e;
  }
  Vec sample_raw(Rng& rng) const override {
    Vec q(4);
    q << rng.uniform(-half_w, half_w), rng.uniform(-half_h, half_h), rng.uniform(-M_PI, M_PI),
        rng.uniform(-steer_max, steer_max);
    return q;
  }
};

// ---- D: planar double integrator, acceleration control --------------------
// State [p; v] (4), a_max = 2 m/s^2. Position constraints in the viability
// form c + K cdot <= 0 (K = 1 s, see system.hpp for why this keeps c <= 0);
// speed limits |v_i| <= 1 as plain rows. The obstacle's state [o; odot] is
// uncontrollable with known derivative [odot; oddot].
// Rows: 4 velocity, 4 walls (viability), 1 obstacle (viability).
struct DoubleIntegratorScenario : Scenario {
  DoubleIntegratorSystem sys{{2.0, 2.0}};
  double K = 1.0, R = 0.2, half_w = 2.0, half_h = 1.5, margin = 0.05, vmax = 1.0;
  MovingDisc obs{{0.0, 0.0}, {0.8, 0.4}, 0.25, 0.35, 0.25};
  DoubleIntegratorScenario() {
    name = "double_integrator";
    model = default_projector_model(4, 2, 9, 4);
    for (int i = 0; i < 4; ++i) model.beta[i] = 10.0;
    for (int i = 4; i < 9; ++i) model.beta[i] = 5.0;
    model.has_drift = true;
  }
  int n() const override { return 4; }
  Eval eval(const Vec& q, double t) const override {
    Eval e;
    e.f = Vec::Zero(4);
    Eigen::Matrix<double, 4, 2, Eigen::RowMajor> Gr;
    sys.eval(q.data(), e.f.data(), Gr.data());
    e.G = Gr;
    e.c.resize(9);
    e.Jq = Mat::Zero(9, 4);
    e.Jx = Mat::Zero(9, 4);
    for (int i = 0; i < 2; ++i) {
      e.c(2 * i) = q(2 + i) - vmax; e.Jq(2 * i, 2 + i) = 1;
      e.c(2 * i + 1) = -vmax - q(2 + i); e.Jq(2 * i + 1, 2 + i) = -1;
    }
    // Walls: c = +-(p_i) + R + margin - half, viability c + K * (+-v_i).
    const double lim[2] = {half_w, half_h};
    for (int i = 0; i < 2; ++i) {
      for (int sgn = 0; sgn < 2; ++sgn) {
        const double sg = sgn ? -1.0 : 1.0;
        const double c = sg * q(i) + R + margin - lim[i];
        const double J[2] = {sg, 0.0};  // dc/dp_i (1-D), H = 0 (linear)
        const double H[2] = {0.0, 0.0};
        double cv, Jv[2];
        viability_constraint(1, 1, &c, J, H, &q(2 + i), &K, &cv, Jv);
        const int row = 4 + 2 * i + sgn;
        e.c(row) = cv;
        e.Jq(row, i) = Jv[0];
        e.Jq(row, 2 + i) = Jv[1];
      }
    }
    // Obstacle: c = r_o + R + margin - |p - o|, cdot = -u . (v - odot),
    // viability c_v = c - K u . w with w = v - odot.
    const Eigen::Vector2d o = obs.pos(t), od = obs.vel(t);
    const Eigen::Vector2d p = q.head(2), v = q.tail(2);
    const Eigen::Vector2d diff = p - o;
    const double dist = diff.norm();
    const Eigen::Vector2d u = diff / dist, w = v - od;
    const Eigen::Matrix2d P = (Eigen::Matrix2d::Identity() - u * u.transpose()) / dist;  // du/dp
    e.c(8) = obs.radius + R + margin - dist - K * u.dot(w);
    e.Jq.block<1, 2>(8, 0) = -u.transpose() - K * w.transpose() * P;
    e.Jq.block<1, 2>(8, 2) = -K * u.transpose();
    e.Jx.block<1, 2>(8, 0) = u.transpose() + K * w.transpose() * P;
    e.Jx.block<1, 2>(8, 2) = K * u.transpose();
    e.xdot.resize(4);
    e.xdot << od, obs.acc(t);
    return e;
  }
  Vec sample_raw(Rng& rng) const override {
    Vec q(4);
    q << rng.uniform(-half_w, half_w), rng.uniform(-half_h, half_h), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5);
    return q;
  }
};

}  // namespace atacom::test
