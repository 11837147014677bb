// Undistorted phone V frames: a pinhole camera for the calibrated lens and
// the resampled images (linear half EXR and 8-bit sRGB PNG), so later
// stages only ever see pinhole cameras.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "calib/calib_options.h"
#include "core/camera.h"

namespace relit::calib {

// The pinhole camera (same image size, square pixels, centred principal
// point) for images taken with `distorted`. alpha = 0: every pinhole pixel
// sees the scene (crops the borders), alpha = 1: every source pixel is kept.
Intrinsics PinholeFor(const Intrinsics& distorted, double alpha);

class FrameUndistorter {
 public:
  // `interpolation`: one of UndistortInterpolationNames().
  FrameUndistorter(const Intrinsics& distorted, const Intrinsics& pinhole,
                   const std::string& interpolation = UndistortOptions().interpolation);

  // Resamples a linear EXR (in linear light, overshoot below zero clipped)
  // and an 8-bit sRGB image; writes both (parents created, files replaced
  // atomically).
  void Run(const std::string& linear_in, const std::string& srgb_in, const std::string& linear_out,
           const std::string& srgb_out) const;

  // 8-bit sRGB only (geometry-pass frames have no linear copy).
  void RunSrgb(const std::string& srgb_in, const std::string& srgb_out) const;

  cv::Mat Remap(const cv::Mat& image) const;

 private:
  cv::Mat map_x_, map_y_;
  int interpolation_;  // cv::InterpolationFlags
};

}  // namespace relit::calib
