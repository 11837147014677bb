#include "reconstruct/photo_refine.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/core/eigen.hpp>
#include <tbb/parallel_for.h>

#include "core/error.h"

namespace relit::reconstruct {

void PhotoRefineStats::Add(const PhotoRefineStats& o) {
  const int64_t total = refined_px + o.refined_px;
  if (total > 0) mean_shift_m = (mean_shift_m * refined_px + o.mean_shift_m * o.refined_px) / total;
  depth_px += o.depth_px;
  refined_px += o.refined_px;
  flat_px += o.flat_px;
  dropped_px += o.dropped_px;
  unseen_px += o.unseen_px;
}

nlohmann::json PhotoRefineStats::ToJson() const {
  return {{"depth_px", depth_px},   {"refined_px", refined_px}, {"flat_px", flat_px},
          {"dropped_px", dropped_px}, {"unseen_px", unseen_px},  {"mean_shift_m", mean_shift_m}};
}

namespace {

Eigen::Matrix3d CameraMatrix(const Intrinsics& k) {
  Eigen::Matrix3d m;
  cv::cv2eigen(k.CameraMatrix(), m);
  return m;
}

// Bilinear sample of an 8-bit image; false outside (a border pixel's
// neighbourhood counts as outside).
inline bool Sample(const cv::Mat& image, double x, double y, float* value) {
  if (!(x >= 0 && y >= 0 && x < image.cols - 1 && y < image.rows - 1)) return false;
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const uint8_t* row0 = image.ptr<uint8_t>(y0) + x0;
  const uint8_t* row1 = image.ptr<uint8_t>(y0 + 1) + x0;
  const float top = row0[0] + fx * (row0[1] - row0[0]);
  const float bottom = row1[0] + fx * (row1[1] - row1[0]);
  *value = top + fy * (bottom - top);
  return true;
}

struct Neighbour {
  const DepthView* view;
  Eigen::Matrix3d k_other;       // the neighbour's camera matrix
  Eigen::Matrix3d other_from_ref_rotation;
  Eigen::Vector3d other_from_ref_translation;
};

// The point of pixel (u, v) at depth z in `ref`'s camera frame.
inline Eigen::Vector3d PointAt(const Eigen::Matrix3d& k_inv, int u, int v, float z) {
  return k_inv * Eigen::Vector3d(u, v, 1.0) * z;
}

// Unit normal (camera frame, facing the camera) of the least-squares plane
// through the depth map's points within `radius` pixels of (u, v) (those
// within 3 % of its depth: not across a depth edge), or the direction back
// to the camera where the map is too sparse there or the plane is grazing.
Eigen::Vector3d LocalNormal(const cv::Mat& depth, const Eigen::Matrix3d& k_inv, int u, int v, int radius) {
  const float z = depth.at<float>(v, u);
  const Eigen::Vector3d centre = PointAt(k_inv, u, v, z);
  const Eigen::Vector3d towards_camera = -centre.normalized();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  int count = 0;
  for (int y = std::max(0, v - radius); y <= std::min(depth.rows - 1, v + radius); ++y) {
    const float* row = depth.ptr<float>(y);
    for (int x = std::max(0, u - radius); x <= std::min(depth.cols - 1, u + radius); ++x) {
      if (row[x] <= 0 || std::abs(row[x] - z) > 0.03f * z) continue;
      const Eigen::Vector3d p = PointAt(k_inv, x, y, row[x]) - centre;
      sum += p;
      outer += p * p.transpose();
      ++count;
    }
  }
  const int side = 2 * radius + 1;
  if (count < side * side / 2) return towards_camera;
  const Eigen::Vector3d mean = sum / count;
  const Eigen::Matrix3d covariance = outer / count - mean * mean.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  Eigen::Vector3d normal = solver.eigenvectors().col(0);  // smallest eigenvalue
  if (normal.dot(towards_camera) < 0) normal = -normal;
  // Nearly grazing planes are mostly noise: fall back to fronto-parallel.
  return normal.dot(towards_camera) < 0.2 ? towards_camera : normal;
}

}  // namespace

cv::Mat RefineDepthMapPhotometric(const DepthView& ref, const cv::Mat& depth, const std::vector<const DepthView*>& others,
                                  const SceneBox& box, const PhotoRefineOptions& options, PhotoRefineStats* stats) {
  RELIT_REQUIRE(depth.type() == CV_32F && depth.rows == ref.gray.rows && depth.cols == ref.gray.cols,
                "photometric refinement: the depth map of ", ref.name, " does not match its image");
  RELIT_REQUIRE(ref.gray.type() == CV_8U, "photometric refinement: ", ref.name, " is not an 8-bit grey image");
  cv::Mat refined = depth.clone();
  PhotoRefineStats local;
  if (others.empty()) {
    *stats = local;
    return refined;
  }
  const Eigen::Matrix3d k_ref = CameraMatrix(ref.camera.intrinsics());
  const Eigen::Matrix3d k_inv = k_ref.inverse();
  const Rigid3 world_from_ref = ref.camera.world_from_cam();
  std::vector<Neighbour> neighbours;
  for (const DepthView* other : others) {
    const Rigid3 other_from_ref = other->camera.cam_from_world() * world_from_ref;
    neighbours.push_back({other, CameraMatrix(other->camera.intrinsics()), other_from_ref.rotation.toRotationMatrix(),
                          other_from_ref.translation});
  }
  const int radius = options.window_radius_px;
  const int side = 2 * radius + 1;
  const int window = side * side;
  const int steps = options.search_steps;
  const int hypotheses = 2 * steps + 1;
  const double step_fraction = options.search_fraction / steps;
  const int views = static_cast<int>(neighbours.size());
  const int best_of = std::max(1, (views + 1) / 2);
  std::vector<float> ref_window(window), weights(window), spatial_weights(window);
  const double color_sigma = options.color_sigma;
  const float color_scale = color_sigma > 0 ? static_cast<float>(1.0 / (2 * color_sigma * color_sigma)) : 0.0f;
  for (int dy = -radius, q = 0; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx, ++q) {
      spatial_weights[q] = static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2.0 * radius * radius)));
    }
  }
  std::vector<float> ncc(static_cast<size_t>(views) * hypotheses);
  std::vector<float> score(hypotheses), view_scores;
  std::vector<bool> view_ok(views);
  double shift_sum = 0;

  for (int v = radius; v < depth.rows - radius; ++v) {
    for (int u = radius; u < depth.cols - radius; ++u) {
      const float z = depth.at<float>(v, u);
      if (z <= 0) continue;
      const Eigen::Vector3d point = PointAt(k_inv, u, v, z);
      const Eigen::Vector3d world = world_from_ref * point;
      if ((world.array() < box.min.array()).any() || (world.array() > box.max.array()).any()) continue;
      ++local.depth_px;

      // The reference window. With color_sigma, pixels unlike the
      // centre (likely another surface) weigh less (bilateral weights, as
      // COLMAP's PatchMatch): a window across a silhouette then follows the
      // centre's surface. ref_window holds w (r - mean_w) / |.|_w.
      const float centre_value = ref.gray.at<uint8_t>(v, u);
      double weight_sum = 0, mean = 0;
      for (int dy = -radius, q = 0; dy <= radius; ++dy) {
        const uint8_t* row = ref.gray.ptr<uint8_t>(v + dy);
        for (int dx = -radius; dx <= radius; ++dx, ++q) {
          ref_window[q] = row[u + dx];
          const float difference = ref_window[q] - centre_value;
          weights[q] = color_sigma > 0 ? spatial_weights[q] * std::exp(-difference * difference * color_scale) : 1.0f;
          weight_sum += weights[q];
          mean += weights[q] * ref_window[q];
        }
      }
      mean /= weight_sum;
      double norm2 = 0;
      for (int q = 0; q < window; ++q) {
        ref_window[q] -= static_cast<float>(mean);
        norm2 += weights[q] * ref_window[q] * ref_window[q];
      }
      if (std::sqrt(norm2 / weight_sum) < options.min_texture) {
        ++local.flat_px;
        continue;
      }
      const float ref_scale = static_cast<float>(1.0 / std::sqrt(norm2));
      for (int q = 0; q < window; ++q) ref_window[q] *= ref_scale * weights[q];

      const Eigen::Vector3d normal = LocalNormal(depth, k_inv, u, v, options.window_radius_px);
      const double plane_offset = normal.dot(point);  // n . X = offset (< 0: the plane faces the camera)
      std::fill(view_ok.begin(), view_ok.end(), true);
      for (int j = 0; j < views; ++j) {
        const Neighbour& nb = neighbours[j];
        for (int h = 0; h < hypotheses && view_ok[j]; ++h) {
          const double offset = plane_offset * (1.0 + (h - steps) * step_fraction);
          // Plane-induced homography ref pixel -> neighbour pixel.
          const Eigen::Matrix3d homography =
              nb.k_other * (nb.other_from_ref_rotation + nb.other_from_ref_translation * normal.transpose() / offset) *
              k_inv;
          // Weighted NCC: cov = sum a_q o_q with a = ref_window (its
          // weighted mean is zero), var_o = sum w o^2 - (sum w o)^2 / sum w.
          double dot = 0, weighted_sum = 0, weighted_sum2 = 0;
          for (int dy = -radius, q = 0; dy <= radius && view_ok[j]; ++dy) {
            for (int dx = -radius; dx <= radius; ++dx, ++q) {
              const Eigen::Vector3d p = homography * Eigen::Vector3d(u + dx, v + dy, 1.0);
              float value = 0;
              if (p.z() <= 0 || !Sample(nb.view->gray, p.x() / p.z(), p.y() / p.z(), &value)) {
                view_ok[j] = false;
                break;
              }
              dot += ref_window[q] * value;
              weighted_sum += weights[q] * value;
              weighted_sum2 += weights[q] * value * value;
            }
          }
          if (!view_ok[j]) break;
          const double variance = weighted_sum2 - weighted_sum * weighted_sum / weight_sum;
          ncc[j * hypotheses + h] = variance > 1e-6 ? static_cast<float>(dot / std::sqrt(variance)) : 0.0f;
        }
      }
      int usable = 0;
      for (int j = 0; j < views; ++j) usable += view_ok[j] ? 1 : 0;
      if (usable == 0) {
        ++local.unseen_px;
        continue;
      }
      const int best_count = std::min(best_of, usable);
      for (int h = 0; h < hypotheses; ++h) {
        view_scores.clear();
        for (int j = 0; j < views; ++j) {
          if (view_ok[j]) view_scores.push_back(ncc[j * hypotheses + h]);
        }
        std::partial_sort(view_scores.begin(), view_scores.begin() + best_count, view_scores.end(),
                          std::greater<float>());
        float sum = 0;
        for (int b = 0; b < best_count; ++b) sum += view_scores[b];
        score[h] = sum / best_count;
      }
      const int best = static_cast<int>(std::max_element(score.begin(), score.end()) - score.begin());
      if (best == 0 || best == hypotheses - 1 || score[best] < options.min_score) {
        refined.at<float>(v, u) = 0;
        ++local.dropped_px;
        continue;
      }
      const double below = score[best - 1], at = score[best], above = score[best + 1];
      const double curvature = below - 2 * at + above;
      const double sub = curvature < 0 ? std::clamp(0.5 * (below - above) / curvature, -0.5, 0.5) : 0.0;
      // Depth along the ray scales with the plane offset.
      const float z_new = static_cast<float>(z * (1.0 + (best - steps + sub) * step_fraction));
      refined.at<float>(v, u) = z_new;
      shift_sum += std::abs(z_new - z);
      ++local.refined_px;
    }
  }
  local.mean_shift_m = local.refined_px > 0 ? shift_sum / local.refined_px : 0.0;
  *stats = local;
  return refined;
}

std::vector<cv::Mat> RefineDepthMapsPhotometric(const std::vector<DepthView>& views, const std::vector<cv::Mat>& depths,
                                                const Eigen::Vector3d& centre, const SceneBox& box,
                                                const ProxyOptions& options, PhotoRefineStats* stats,
                                                const std::function<void()>& on_frame_done) {
  RELIT_REQUIRE(views.size() == depths.size(), "photometric refinement: ", views.size(), " views but ",
                depths.size(), " depth maps");
  std::vector<Camera> cameras;
  for (const DepthView& view : views) cameras.push_back(view.camera);
  ProxyOptions selection = options;
  selection.neighbours = options.photo.views;
  selection.min_baseline_deg = std::min(options.min_baseline_deg, options.photo.max_baseline_deg);
  selection.target_baseline_deg = std::clamp(options.target_baseline_deg, selection.min_baseline_deg,
                                             options.photo.max_baseline_deg);
  selection.max_baseline_deg = options.photo.max_baseline_deg;
  const std::vector<std::vector<int>> neighbours = SelectStereoNeighbours(cameras, centre, selection);
  std::vector<cv::Mat> refined(views.size());
  std::vector<PhotoRefineStats> frame_stats(views.size());
  tbb::parallel_for(size_t(0), views.size(), [&](size_t i) {
    std::vector<const DepthView*> others;
    for (const int j : neighbours[i]) others.push_back(&views[j]);
    refined[i] = RefineDepthMapPhotometric(views[i], depths[i], others, box, options.photo, &frame_stats[i]);
    if (on_frame_done) on_frame_done();
  });
  *stats = PhotoRefineStats{};
  for (const PhotoRefineStats& s : frame_stats) stats->Add(s);
  return refined;
}

}  // namespace relit::reconstruct
