// Similarity transforms (scale, rotation, translation) between point sets:
// Umeyama's closed form and a RANSAC wrapper robust to outliers, used to put
// the COLMAP model into the metric board frame.
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera.h"

namespace relit::calib {

struct Similarity3 {
  double scale = 1;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return scale * (rotation * x) + translation; }
  // cam_from_world for a camera given as cam_from_model, where this
  // similarity is world_from_model.
  Rigid3 CamFromWorld(const Rigid3& cam_from_model) const;
};

// Least-squares similarity with dst ~ S * src (Umeyama 1991). Needs >= 3
// non-collinear pairs; returns false otherwise.
bool FitSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   Similarity3* result);

struct RobustFit {
  Similarity3 transform;
  std::vector<bool> inliers;
  int inlier_count = 0;
  double rms_m = 0;   // over inliers
};

// RANSAC over minimal samples (deterministic sampling, `iterations` draws),
// inliers within `inlier_m`, then a least-squares fit on the inliers.
// Returns false with fewer than 3 inliers.
bool FitSimilarityRobust(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                         double inlier_m, int iterations, RobustFit* result);

}  // namespace relit::calib
