// Control-affine systems qdot = f(q) + G(q) a, with a in [-1, 1]^m (G carries
// the physical scale). Each system is a small constant model with a per-state
// evaluation; batched callers loop over their env range. Dense G is row-major
// (n x m).
#pragma once
#include <cmath>
#include <vector>

namespace atacom {

// Velocity-controlled holonomic arm: f = 0, G = diag(vmax).
struct VelocityArmSystem {
  std::vector<double> vmax;  // (n) joint velocity at |a| = 1
  int n() const { return static_cast<int>(vmax.size()); }
  int m() const { return n(); }
  void eval(const double* /*q*/, double* f, double* G) const {
    const int d = n();
    for (int i = 0; i < d; ++i) {
      f[i] = 0.0;
      for (int j = 0; j < d; ++j) G[i * d + j] = i == j ? vmax[i] : 0.0;
    }
  }
};

// Differential drive, q = [x, y, theta], a = [v, omega] (normalised):
// xdot = v_max a0 cos(theta), ydot = v_max a0 sin(theta), thetadot = w_max a1.
struct DiffDriveSystem {
  double v_max = 1.0;
  double w_max = M_PI / 3.0;
  static constexpr int n() { return 3; }
  static constexpr int m() { return 2; }
  void eval(const double* q, double* f, double* G) const {
    f[0] = f[1] = f[2] = 0.0;
    G[0] = v_max * std::cos(q[2]); G[1] = 0.0;
    G[2] = v_max * std::sin(q[2]); G[3] = 0.0;
    G[4] = 0.0;                    G[5] = w_max;
  }
};

// Kinematic bicycle about the rear axle, q = [x, y, theta, delta],
// a = [v, delta_rate] (normalised): xdot = v cos(theta), ydot = v sin(theta),
// thetadot = v tan(delta) / L, deltadot = delta_rate. Control-affine because
// the steering angle is a state. Keep |delta| < pi/2 with a constraint.
struct BicycleSystem {
  double wheelbase = 0.5;
  double v_max = 1.0;
  double steer_rate_max = 1.0;
  static constexpr int n() { return 4; }
  static constexpr int m() { return 2; }
  void eval(const double* q, double* f, double* G) const {
    f[0] = f[1] = f[2] = f[3] = 0.0;
    G[0] = v_max * std::cos(q[2]);                 G[1] = 0.0;
    G[2] = v_max * std::sin(q[2]);                 G[3] = 0.0;
    G[4] = v_max * std::tan(q[3]) / wheelbase;     G[5] = 0.0;
    G[6] = 0.0;                                    G[7] = steer_rate_max;
  }
};

// Double integrator with acceleration control, state [q; qdot] (2d):
// f = [qdot; 0], G = [0; diag(a_max)].
struct DoubleIntegratorSystem {
  std::vector<double> a_max;  // (d)
  int d() const { return static_cast<int>(a_max.size()); }
  int n() const { return 2 * d(); }
  int m() const { return d(); }
  void eval(const double* x, double* f, double* G) const {
    const int dd = d(), nn = n();
    for (int i = 0; i < dd; ++i) { f[i] = x[dd + i]; f[dd + i] = 0.0; }
    for (int i = 0; i < nn; ++i)
      for (int j = 0; j < dd; ++j) G[i * dd + j] = (i >= dd && i - dd == j) ? a_max[j] : 0.0;
  }
};

// Explicit Euler step q += dt (f + G a) for any system above.
template <class System>
void euler_step(const System& sys, double* q, const double* a, double dt, double* f_scratch, double* G_scratch) {
  sys.eval(q, f_scratch, G_scratch);
  const int n = sys.n(), m = sys.m();
  for (int i = 0; i < n; ++i) {
    double v = f_scratch[i];
    for (int j = 0; j < m; ++j) v += G_scratch[i * m + j] * a[j];
    q[i] += dt * v;
  }
}

// Viability form of a position constraint for the double integrator
// (acceleration control): c_v(q, qdot) = c(q) + K J(q) qdot <= 0.
// If c_v <= 0 holds along a trajectory that starts with c <= 0, then
// cdot <= -c / K, so c can never cross zero: keeping the viability constraint
// keeps the position constraint, while leaving room to brake.
// Given c (k), J = dc/dq (k x d) and H = d(J(q) qdot)/dq (k x d), writes c_v (k)
// and its Jacobian wrt the full state [q; qdot]: [J + K H, K J] (k x 2d).
void viability_constraint(int k, int d, const double* c, const double* J, const double* H, const double* qdot,
                          const double* K, double* c_v, double* J_v);

}  // namespace atacom
