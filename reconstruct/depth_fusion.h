// Multi-view geometric consistency and fusion of per-view depth maps into
// one point cloud (the dense proxy path): a depth pixel survives when it
// lies in the crop region above the board and at least
// options.min_consistent_views other frames, and options.min_consistent_fraction
// of those with a depth where it projects, measured the same depth there;
// the survivor is the mean of the agreeing 3D points and remembers the
// direction to the camera that measured it (to orient its normal).
#pragma once

#include <cmath>
#include <functional>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct FusedPoint {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();   // world
  Eigen::Vector3d to_camera = Eigen::Vector3d::UnitZ();    // unit, towards the observing camera
};

struct FrameFusionStats {
  int depth_px = 0;        // pixels with a stereo depth
  int in_crop_px = 0;      // ... whose point lies in the crop region above the board
  int consistent_px = 0;   // ... confirmed by enough other frames
  nlohmann::json ToJson() const;
};

// `depths[i]` is the CV_32F depth map (0 = none) of `cameras[i]`.
// Thread-parallel over frames; `on_frame_done` (may be empty) is called once
// per frame from worker threads.
// With `consistent_depths`, also each depth map keeping only the pixels that
// at least options.min_consistent_views (>= 1) other frames agree with (no
// share: the hull and the refinement were tuned without it), over
// the whole frame (the table too): stereo mismatches on dark or textureless
// parts rarely agree, so these are the depths the hull and the proxy
// refinement may trust to say "this ray is empty up to here".
std::vector<FusedPoint> FuseDepthMaps(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& depths,
                                      const CropRegion& crop, const ProxyOptions& options,
                                      std::vector<FrameFusionStats>* stats,
                                      std::vector<cv::Mat>* consistent_depths = nullptr,
                                      const std::function<void()>& on_frame_done = {});

// The pixel nearest to where a camera-frame point projects, in an image of
// `size`; false when the point is behind the camera or falls outside.
// Inline: the fusion and the hull call it per point and view.
inline bool NearestPixel(const Camera& camera, const Eigen::Vector3d& point_cam, const cv::Size& size,
                         cv::Point* pixel) {
  if (point_cam.z() <= 0) return false;
  const Eigen::Vector2d projected = camera.ProjectCameraPoint(point_cam);
  pixel->x = static_cast<int>(std::lround(projected.x()));
  pixel->y = static_cast<int>(std::lround(projected.y()));
  return pixel->x >= 0 && pixel->y >= 0 && pixel->x < size.width && pixel->y < size.height;
}

// The nearest valid depth of each pixel's 3x3 neighbourhood (0 where none):
// free-space tests use it so that a projection rounded onto an object's rim
// does not see through the object.
cv::Mat NearestDepth3x3(const cv::Mat& depth);

// True for a world point inside the crop cylinder and above min_height_m.
bool InCrop(const Eigen::Vector3d& p, const CropRegion& crop, double min_height_m);

}  // namespace relit::reconstruct
