#include "reconstruct/depth_fusion.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <opencv2/imgproc.hpp>

#include <tbb/parallel_for.h>

namespace relit::reconstruct {

nlohmann::json FrameFusionStats::ToJson() const {
  return {{"depth_px", depth_px}, {"in_crop_px", in_crop_px}, {"consistent_px", consistent_px}};
}

cv::Mat NearestDepth3x3(const cv::Mat& depth) {
  constexpr float kUnknown = std::numeric_limits<float>::max();
  cv::Mat filled = depth.clone();
  filled.setTo(kUnknown, depth <= 0);
  cv::Mat nearest;
  cv::erode(filled, nearest, cv::Mat::ones(3, 3, CV_8U), cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  nearest.setTo(0, nearest >= kUnknown);
  return nearest;
}

bool InCrop(const Eigen::Vector3d& p, const CropRegion& crop, double min_height_m) {
  return p.z() > min_height_m && (p.head<2>() - crop.centre_xy).norm() < crop.radius_m;
}

namespace {

struct ViewPose {
  Rigid3 world_from_cam;
  Eigen::Vector3d centre;
};

std::vector<ViewPose> Poses(const std::vector<Camera>& cameras) {
  std::vector<ViewPose> poses;
  for (const Camera& camera : cameras) poses.push_back({camera.world_from_cam(), camera.Center()});
  return poses;
}

// The other frames whose depth maps hold `point` (within
// options.depth_tolerance); their 3D points are added to *sum and the
// frames with any depth where it projects are counted in *with_depth (both
// may be null). Stops counting at `enough` (0 = count all).
int AgreeingViews(const Eigen::Vector3d& point, size_t self, const std::vector<Camera>& cameras,
                  const std::vector<ViewPose>& poses, const std::vector<cv::Mat>& depths,
                  const ProxyOptions& options, int enough, Eigen::Vector3d* sum, int* with_depth) {
  int agreeing = 0;
  for (size_t k = 0; k < cameras.size(); ++k) {
    if (k == self) continue;
    const Eigen::Vector3d in_k = cameras[k].cam_from_world() * point;
    cv::Point pixel;
    if (!NearestPixel(cameras[k], in_k, depths[k].size(), &pixel)) continue;
    const float zk = depths[k].at<float>(pixel);
    if (with_depth && zk > 0) ++*with_depth;
    if (zk <= 0 || std::abs(zk - in_k.z()) > options.depth_tolerance * in_k.z()) continue;
    if (sum) {
      const Eigen::Vector3d ray_k = cameras[k].PixelToCameraRay(Eigen::Vector2d(pixel.x, pixel.y));
      *sum += poses[k].world_from_cam * (ray_k * (zk / ray_k.z()));
    }
    if (++agreeing == enough) break;
  }
  return agreeing;
}

}  // namespace

std::vector<FusedPoint> FuseDepthMaps(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& depths,
                                      const CropRegion& crop, const ProxyOptions& options,
                                      std::vector<FrameFusionStats>* stats, std::vector<cv::Mat>* consistent_depths,
                                      const std::function<void()>& on_frame_done) {
  const size_t n = cameras.size();
  const std::vector<ViewPose> poses = Poses(cameras);
  stats->assign(n, FrameFusionStats{});
  if (consistent_depths) consistent_depths->assign(n, cv::Mat());
  const int enough = std::max(1, options.min_consistent_views);
  std::vector<std::vector<FusedPoint>> per_frame(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    const Camera& camera = cameras[i];
    const cv::Mat& depth = depths[i];
    FrameFusionStats& s = (*stats)[i];
    cv::Mat consistent;
    if (consistent_depths) consistent = cv::Mat(depth.size(), CV_32F, cv::Scalar(0));
    for (int v = 0; v < depth.rows; ++v) {
      for (int u = 0; u < depth.cols; ++u) {
        const float z = depth.at<float>(v, u);
        if (z <= 0) continue;
        ++s.depth_px;
        const Eigen::Vector3d ray = camera.PixelToCameraRay(Eigen::Vector2d(u, v));
        const Eigen::Vector3d point = poses[i].world_from_cam * (ray * (z / ray.z()));
        if (!InCrop(point, crop, options.min_height_m)) {
          // Outside the crop only the consistent map wants it: stop counting at `enough`.
          if (consistent_depths &&
              AgreeingViews(point, i, cameras, poses, depths, options, enough, nullptr, nullptr) >= enough) {
            consistent.at<float>(v, u) = z;
          }
          continue;
        }
        ++s.in_crop_px;
        Eigen::Vector3d sum = point;
        int with_depth = 0;
        const int agreeing = AgreeingViews(point, i, cameras, poses, depths, options, 0, &sum, &with_depth);
        if (consistent_depths && agreeing >= enough) consistent.at<float>(v, u) = z;
        const int required = std::max(options.min_consistent_views,
                                      static_cast<int>(std::ceil(options.min_consistent_fraction * with_depth)));
        if (agreeing < required) continue;
        ++s.consistent_px;
        FusedPoint fused;
        fused.position_m = sum / (agreeing + 1);
        fused.to_camera = (poses[i].centre - fused.position_m).normalized();
        per_frame[i].push_back(fused);
      }
    }
    if (consistent_depths) (*consistent_depths)[i] = consistent;
    if (on_frame_done) on_frame_done();
  });
  std::vector<FusedPoint> points;
  for (const std::vector<FusedPoint>& frame_points : per_frame) {
    points.insert(points.end(), frame_points.begin(), frame_points.end());
  }
  return points;
}

}  // namespace relit::reconstruct
