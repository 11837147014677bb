#include "calib/align.h"

#include <cmath>
#include <random>

#include <Eigen/SVD>

namespace relit::calib {

Rigid3 Similarity3::CamFromWorld(const Rigid3& cam_from_model) const {
  // x_model = R^T (x_world - t) / s; the camera frame is scaled by s to metres.
  const Eigen::Matrix3d r_c = cam_from_model.rotation.toRotationMatrix();
  const Eigen::Matrix3d r = r_c * rotation.transpose();
  return Rigid3(r, scale * cam_from_model.translation - r * translation);
}

bool FitSimilarity(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                   Similarity3* result) {
  const size_t n = src.size();
  if (n < 3 || dst.size() != n) return false;
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero(), mean_dst = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= n;
  mean_dst /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double var_src = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = src[i] - mean_src, b = dst[i] - mean_dst;
    cov += b * a.transpose();
    var_src += a.squaredNorm();
  }
  cov /= n;
  var_src /= n;
  if (var_src < 1e-20) return false;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (sv(1) < 1e-12 * std::max(1.0, sv(0))) return false;  // collinear
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) s(2, 2) = -1;
  result->rotation = svd.matrixU() * s * svd.matrixV().transpose();
  result->scale = (sv.asDiagonal() * s).trace() / var_src;
  result->translation = mean_dst - result->scale * result->rotation * mean_src;
  return std::isfinite(result->scale) && result->scale > 0;
}

bool FitSimilarityRobust(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst,
                         double inlier_m, int iterations, RobustFit* result) {
  const int n = static_cast<int>(src.size());
  if (n < 3) return false;
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> pick(0, n - 1);
  int best_count = 0;
  std::vector<bool> best;
  auto score = [&](const Similarity3& s, std::vector<bool>* inliers) {
    int count = 0;
    inliers->assign(n, false);
    for (int i = 0; i < n; ++i) {
      if ((s * src[i] - dst[i]).norm() <= inlier_m) {
        (*inliers)[i] = true;
        ++count;
      }
    }
    return count;
  };
  for (int it = 0; it < iterations; ++it) {
    const int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    Similarity3 s;
    if (!FitSimilarity({src[a], src[b], src[c]}, {dst[a], dst[b], dst[c]}, &s)) continue;
    std::vector<bool> inliers;
    const int count = score(s, &inliers);
    if (count > best_count) {
      best_count = count;
      best = inliers;
    }
  }
  if (best_count < 3) return false;
  // Refit on the inliers, then rescore once more.
  for (int round = 0; round < 2; ++round) {
    std::vector<Eigen::Vector3d> s_in, d_in;
    for (int i = 0; i < n; ++i) {
      if (best[i]) {
        s_in.push_back(src[i]);
        d_in.push_back(dst[i]);
      }
    }
    if (!FitSimilarity(s_in, d_in, &result->transform)) return false;
    std::vector<bool> inliers;
    const int count = score(result->transform, &inliers);
    if (count < 3) return false;
    best = inliers;
    best_count = count;
  }
  result->inliers = best;
  result->inlier_count = best_count;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    if (best[i]) sum += (result->transform * src[i] - dst[i]).squaredNorm();
  }
  result->rms_m = std::sqrt(sum / best_count);
  return true;
}

}  // namespace relit::calib
