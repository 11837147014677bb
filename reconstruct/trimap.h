// Trimaps from the projected proxy: the proxy's silhouette in a view (Embree
// ray casting through every pixel centre), eroded for the known foreground,
// dilated for the known background, the band between unknown.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/render/scene.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

constexpr uint8_t kTrimapBackground = 0;
constexpr uint8_t kTrimapUnknown = 128;
constexpr uint8_t kTrimapForeground = 255;

// CV_8U, 255 where the ray through the pixel centre hits the scene, else 0.
cv::Mat ProjectSilhouette(const render::Scene& scene, const Camera& camera);

// Half width of the unknown band in pixels for a view whose object centre
// lies at `centre_depth_m` in front of the camera.
int TrimapBandPx(const TrimapOptions& options, const Intrinsics& intrinsics, double centre_depth_m);

// CV_8U trimap (0 / 128 / 255) from a 0/255 silhouette and the band half width.
cv::Mat MakeTrimap(const cv::Mat& silhouette, int band_px);

}  // namespace relit::reconstruct
