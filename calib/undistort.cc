#include "calib/undistort.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/image.h"
#include "core/option_fields.h"

namespace relit::calib {

namespace fs = std::filesystem;

Intrinsics PinholeFor(const Intrinsics& distorted, double alpha) {
  distorted.Check();
  // Undistorted normalised coordinates of the source border, per side. The
  // pinhole image is centred; each of its borders must stay inside the
  // source border (alpha 0) or outside it (alpha 1).
  const double w = distorted.width - 1, h = distorted.height - 1;
  const double half_w = 0.5 * w, half_h = 0.5 * h;
  auto undistort = [&](double px, double py) {
    const Eigen::Vector2d d((px - distorted.cx) / distorted.fx, (py - distorted.cy) / distorted.fy);
    return Undistort(distorted.distortion, d);
  };
  const double inf = std::numeric_limits<double>::infinity();
  double left_in = inf, left_out = 0, right_in = inf, right_out = 0;
  double top_in = inf, top_out = 0, bottom_in = inf, bottom_out = 0;
  const int steps = 64;
  for (int i = 0; i <= steps; ++i) {
    const double s = static_cast<double>(i) / steps;
    // Distances from the optical axis, which the centred pinhole shares.
    const double l = -undistort(0, s * h).x(), r = undistort(w, s * h).x();
    const double t = -undistort(s * w, 0).y(), b = undistort(s * w, h).y();
    left_in = std::min(left_in, l), left_out = std::max(left_out, l);
    right_in = std::min(right_in, r), right_out = std::max(right_out, r);
    top_in = std::min(top_in, t), top_out = std::max(top_out, t);
    bottom_in = std::min(bottom_in, b), bottom_out = std::max(bottom_out, b);
  }
  RELIT_REQUIRE(left_in > 0 && right_in > 0 && top_in > 0 && bottom_in > 0,
                "the calibrated lens is implausible (its principal point lies outside the image)");
  const double f_inner = std::max({half_w / left_in, half_w / right_in, half_h / top_in, half_h / bottom_in});
  const double f_outer = std::min({half_w / left_out, half_w / right_out, half_h / top_out, half_h / bottom_out});
  Intrinsics pinhole;
  pinhole.width = distorted.width;
  pinhole.height = distorted.height;
  pinhole.fx = pinhole.fy = (1 - alpha) * f_inner + alpha * f_outer;
  pinhole.cx = half_w;
  pinhole.cy = half_h;
  pinhole.Check();
  return pinhole;
}

namespace {

int OpenCvInterpolation(const std::string& name) {
  if (name == "cubic") return cv::INTER_CUBIC;
  if (name == "lanczos4") return cv::INTER_LANCZOS4;
  if (name == "linear") return cv::INTER_LINEAR;
  Fail("undistort.interpolation: ", internal::ChoiceError(name, UndistortInterpolationNames()));
}

}  // namespace

FrameUndistorter::FrameUndistorter(const Intrinsics& distorted, const Intrinsics& pinhole,
                                   const std::string& interpolation)
    : interpolation_(OpenCvInterpolation(interpolation)) {
  UndistortionMaps(distorted, pinhole, &map_x_, &map_y_);
}

cv::Mat FrameUndistorter::Remap(const cv::Mat& image) const {
  cv::Mat out;
  cv::remap(image, out, map_x_, map_y_, interpolation_, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  // Cubic and Lanczos kernels overshoot at edges; radiance and coverage are
  // never negative (8-bit images saturate by themselves).
  if (out.depth() == CV_32F || out.depth() == CV_64F) out = cv::max(out, 0.0);
  return out;
}

void FrameUndistorter::Run(const std::string& linear_in, const std::string& srgb_in,
                           const std::string& linear_out, const std::string& srgb_out) const {
  const Image linear = ReadImage(linear_in);
  RELIT_REQUIRE(linear.width() == map_x_.cols && linear.height() == map_x_.rows, linear_in, " is ",
                linear.width(), "x", linear.height(), " but the calibrated lens is ", map_x_.cols, "x",
                map_x_.rows, ": rerun relit-capture and relit-calib");
  Image remapped = Image::FromMat(Remap(linear.ToMat()));
  remapped.set_channel_names(linear.channel_names());
  fs::create_directories(fs::path(linear_out).parent_path());
  WriteImage(linear_out, remapped, PixelStorage::kHalf);
  RunSrgb(srgb_in, srgb_out);
}

void FrameUndistorter::RunSrgb(const std::string& srgb_in, const std::string& srgb_out) const {
  const cv::Mat srgb = cv::imread(srgb_in, cv::IMREAD_COLOR);
  RELIT_REQUIRE(!srgb.empty(), "cannot read ", srgb_in, ": rerun relit-capture");
  RELIT_REQUIRE(srgb.cols == map_x_.cols && srgb.rows == map_x_.rows, srgb_in, " is ", srgb.cols, "x", srgb.rows,
                " but the calibrated lens is ", map_x_.cols, "x", map_x_.rows, ": rerun relit-capture and relit-calib");
  fs::create_directories(fs::path(srgb_out).parent_path());
  const std::string temporary = srgb_out + ".tmp.png";
  RELIT_REQUIRE(cv::imwrite(temporary, Remap(srgb)), "cannot write ", srgb_out);
  fs::rename(temporary, srgb_out);
}

}  // namespace relit::calib
