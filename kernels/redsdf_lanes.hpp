// A learned obstacle field evaluated for lane blocks of the arm env: the
// PoIs of kLanes envs (npoi x 3 lane vectors, base_footprint) go through the
// batched network as one small batch on the calling thread. The field is
// static in its frame; a pose input, if the model has one, is a constant of
// the env (the robot body's torso lift) shared by every point.
#pragma once
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "kernels/lanes.hpp"
#include "kernels/redsdf_batch.hpp"

namespace atacom {

struct LearnedObstacle {
  std::shared_ptr<const RedsdfModel> model;
  std::shared_ptr<RedsdfBatch> batch;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // object frame -> base_footprint rotation
  Eigen::Vector3d t = Eigen::Vector3d::Zero();      // object frame origin in base_footprint
  double margin = 0.0;                              // added to every learned row's threshold, m
  std::vector<float> pose;                          // (model pose_dim) shared pose input; empty when 0
};

constexpr int kLearnedMaxPoi = 16;

// d[i] (lanes) and g[i][0..2] (lanes) = grad_p d of point i, npoi <= kLearnedMaxPoi.
void learned_distance_lanes(const LearnedObstacle& o, const lanes::vd (*poi)[3], int npoi, lanes::vd* d,
                            lanes::vd (*g)[3]);

// Scalar twin in double (redsdf_reference): d and, when g != nullptr, grad_p d of one base_footprint point.
double learned_distance_reference(const LearnedObstacle& o, const Eigen::Vector3d& p, Eigen::Vector3d* g);

}  // namespace atacom
