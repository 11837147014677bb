#include "reconstruct/depth_fusion.h"

#include <cmath>
#include <functional>

#include <tbb/parallel_for.h>

namespace relit::reconstruct {

nlohmann::json FrameFusionStats::ToJson() const {
  return {{"depth_px", depth_px}, {"in_crop_px", in_crop_px}, {"consistent_px", consistent_px}};
}

bool InCrop(const Eigen::Vector3d& p, const CropRegion& crop, double min_height_m) {
  return p.z() > min_height_m && (p.head<2>() - crop.centre_xy).norm() < crop.radius_m;
}

std::vector<FusedPoint> FuseDepthMaps(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& depths,
                                      const CropRegion& crop, const ProxyOptions& options,
                                      std::vector<FrameFusionStats>* stats,
                                      const std::function<void()>& on_frame_done) {
  const size_t n = cameras.size();
  stats->assign(n, FrameFusionStats{});
  std::vector<std::vector<FusedPoint>> per_frame(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    const Camera& camera = cameras[i];
    const cv::Mat& depth = depths[i];
    const Rigid3 world_from_cam = camera.world_from_cam();
    const Eigen::Vector3d centre = camera.Center();
    FrameFusionStats& s = (*stats)[i];
    for (int v = 0; v < depth.rows; ++v) {
      for (int u = 0; u < depth.cols; ++u) {
        const float z = depth.at<float>(v, u);
        if (z <= 0) continue;
        ++s.depth_px;
        const Eigen::Vector3d ray = camera.PixelToCameraRay(Eigen::Vector2d(u, v));
        const Eigen::Vector3d point = world_from_cam * (ray * (z / ray.z()));
        if (!InCrop(point, crop, options.min_height_m)) continue;
        ++s.in_crop_px;
        Eigen::Vector3d sum = point;
        int agreeing = 0;
        for (size_t k = 0; k < n; ++k) {
          if (k == i) continue;
          Eigen::Vector2d pixel;
          if (!cameras[k].Project(point, &pixel)) continue;
          const int x = static_cast<int>(std::lround(pixel.x())), y = static_cast<int>(std::lround(pixel.y()));
          if (x < 0 || y < 0 || x >= depths[k].cols || y >= depths[k].rows) continue;
          const float zk = depths[k].at<float>(y, x);
          if (zk <= 0) continue;
          const double expected = (cameras[k].cam_from_world() * point).z();
          if (std::abs(zk - expected) > options.depth_tolerance * expected) continue;
          const Eigen::Vector3d ray_k = cameras[k].PixelToCameraRay(Eigen::Vector2d(x, y));
          sum += cameras[k].world_from_cam() * (ray_k * (zk / ray_k.z()));
          ++agreeing;
        }
        if (agreeing < options.min_consistent_views) continue;
        ++s.consistent_px;
        FusedPoint fused;
        fused.position_m = sum / (agreeing + 1);
        fused.to_camera = (centre - fused.position_m).normalized();
        per_frame[i].push_back(fused);
      }
    }
    if (on_frame_done) on_frame_done();
  });
  std::vector<FusedPoint> points;
  for (const std::vector<FusedPoint>& frame_points : per_frame) {
    points.insert(points.end(), frame_points.begin(), frame_points.end());
  }
  return points;
}

}  // namespace relit::reconstruct
