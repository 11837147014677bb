#include "reconstruct/trimap.h"

#include <cmath>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "core/error.h"

namespace relit::reconstruct {

cv::Mat ProjectSilhouette(const render::Scene& scene, const Camera& camera) {
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  cv::Mat silhouette(height, width, CV_8U, cv::Scalar(0));
  const Eigen::Vector3f origin = camera.Center().cast<float>();
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3f direction = camera.PixelToWorldRay({x, y}).cast<float>();
      render::Hit hit;
      if (scene.Intersect(origin, direction, 0.0f, std::numeric_limits<float>::infinity(), &hit)) {
        silhouette.at<uint8_t>(y, x) = 255;
      }
    }
  });
  return silhouette;
}

int TrimapBandPx(const TrimapOptions& options, const Intrinsics& intrinsics, double centre_depth_m) {
  if (options.band_px > 0) return options.band_px;
  const double diagonal_px = std::hypot(intrinsics.width, intrinsics.height);
  const double proxy_px = centre_depth_m > 0 ? intrinsics.fx * options.proxy_error_m / centre_depth_m : 0.0;
  return options.band_min_px + static_cast<int>(std::lround(options.image_fraction * diagonal_px + proxy_px));
}

cv::Mat MakeTrimap(const cv::Mat& silhouette, int band_px) {
  RELIT_REQUIRE(silhouette.type() == CV_8U && !silhouette.empty(), "reconstruct: bad silhouette image");
  RELIT_REQUIRE(band_px >= 1, "reconstruct: the trimap band must be at least 1 px, got ", band_px);
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * band_px + 1, 2 * band_px + 1));
  cv::Mat foreground, dilated;
  cv::erode(silhouette, foreground, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::dilate(silhouette, dilated, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat trimap(silhouette.size(), CV_8U, cv::Scalar(kTrimapBackground));
  trimap.setTo(kTrimapUnknown, dilated);
  trimap.setTo(kTrimapForeground, foreground);
  return trimap;
}

}  // namespace relit::reconstruct
