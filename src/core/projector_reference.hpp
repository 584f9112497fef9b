// Plain per-env ATACOM projector, written as literally as the paper states it
// (explicit J_u, its pseudo-inverse and the (m+k') x (m+k') null-space
// projector). Slow and obvious on purpose: the batched kernel is tested
// against it.
#pragma once
#include <cstdint>

#include <Eigen/Dense>

#include "atacom/projector.hpp"

namespace atacom {

struct ReferenceInput {
  Eigen::VectorXd f;      // (n)     ignored when !model.has_drift
  Eigen::MatrixXd G;      // (n x m) dense, whatever model.g_form says
  Eigen::VectorXd c;      // (k)
  Eigen::MatrixXd Jq;     // (k x n)
  Eigen::MatrixXd Jx;     // (k x p)
  Eigen::VectorXd xdot;   // (p)
  Eigen::VectorXd alpha;  // (m)
};

struct ReferenceOutput {
  Eigen::VectorXd a;        // (m)   safe control
  Eigen::VectorXd slack_u;  // (k)   slack control (0 on equality rows)
  Eigen::VectorXd s;        // (k)   slack value (0 on equality rows)
  double lambda = 1.0;
  uint32_t status = 0;
  Eigen::MatrixXd Ju;       // (k x (m + k_ineq))  [J_G, A]
  Eigen::MatrixXd N;        // ((m + k_ineq) x m)  tangent basis
  Eigen::VectorXd b;        // (m + k_ineq)        -J_u^+ (F + K_c cbar)
  Eigen::VectorXd rhs;      // (k)                 F + K_c cbar
};

ReferenceOutput project_reference(const ProjectorModel& model, const ReferenceInput& in);

}  // namespace atacom
