// Per-view depth maps for the dense proxy path: each reference frame is
// paired with nearby frames (by triangulation angle), every pair is
// rectified (cv::stereoRectify) and matched with cv::StereoSGBM in both
// directions (left-right consistency), and the disparities are turned into
// a depth map on the reference frame's own pixel grid.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct DepthView {
  std::string name;       // frame name, for messages
  Camera camera;          // undistorted pinhole camera
  cv::Mat gray;           // CV_8U, the camera's size
};

// Axis-aligned world box that holds the object (the crop cylinder's box);
// bounds the disparity search of every pair.
struct SceneBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
};

// For each camera, the indices of up to options.neighbours other cameras
// whose triangulation angle at `centre` lies in [min_baseline_deg,
// max_baseline_deg], closest to target_baseline_deg first, one on each side
// (left/right of the reference camera) before a second on the same side.
std::vector<std::vector<int>> SelectStereoNeighbours(const std::vector<Camera>& cameras,
                                                     const Eigen::Vector3d& centre, const ProxyOptions& options);

// Depth along the optical axis (metres, CV_32F, 0 = unknown) on `ref`'s
// pixel grid from `other`: rectification, SGBM both ways, left-right check.
cv::Mat PairDepthMap(const DepthView& ref, const DepthView& other, const SceneBox& box, const ProxyOptions& options);

// Clears the depths of `depth` (on `gray`'s grid) whose block_size_px
// window of `gray` has a standard deviation below `min_texture` (grey
// levels, 0-255): there SGBM had nothing to match and its smoothness term
// drew a chord. Returns the number of cleared pixels.
int DropTexturelessDepths(const cv::Mat& gray, double min_texture, int block_size_px, cv::Mat* depth);

// Clears the depths of `depth` that have a depth more than `jump_fraction`
// farther within `margin_px` pixels (a square window): SGBM's block carries
// the nearer surface's disparity across an occlusion edge, so the pixels
// beside a drop are the fattened ones. Returns the number cleared.
int DropDepthsNearFartherEdges(int margin_px, double jump_fraction, cv::Mat* depth);

// One depth map of a view from its pairs' maps (PairDepthMap's outputs, the
// same view with different neighbours): where several pairs give a depth the
// agreeing ones (relative difference below options.depth_tolerance) are
// averaged; a pixel whose pairs disagree is dropped.
cv::Mat CombinePairDepthMaps(const std::vector<cv::Mat>& pairs, const ProxyOptions& options);

}  // namespace relit::reconstruct
