// Stereo depth post-processing on hand-made images: DropTexturelessDepths
// clears the depths of a plain patch (where SGBM's smoothness term, not a
// match, set them) and keeps those of a textured one and the image's edge.
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "reconstruct/stereo_depth.h"

namespace relit::reconstruct {
namespace {

// Left half: uniform grey with +/-1 level of noise; right half: a random
// pattern (std ~ 70 grey levels).
cv::Mat HalfPlainHalfTextured(int width, int height) {
  cv::Mat gray(height, width, CV_8U);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> noise(-1, 1), pattern(0, 255);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) gray.at<uint8_t>(v, u) = u < width / 2 ? 128 + noise(rng) : pattern(rng);
  }
  return gray;
}

TEST(StereoDepth, TexturelessDepthsAreDroppedTexturedOnesKept) {
  const int width = 40, height = 20;
  const cv::Mat gray = HalfPlainHalfTextured(width, height);
  cv::Mat depth(height, width, CV_32F, cv::Scalar(0.5f));
  depth.at<float>(5, 30) = 0;  // already unknown: stays unknown, not counted
  const int dropped = DropTexturelessDepths(gray, 8.0, 5, &depth);
  int plain_left = 0, textured_kept = 0, textured = 0;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      // The 5-px window of a pixel within 2 px of the seam sees both halves.
      if (u < width / 2 - 2 && depth.at<float>(v, u) > 0) ++plain_left;
      if (u >= width / 2 + 2 && !(v == 5 && u == 30)) {
        ++textured;
        if (depth.at<float>(v, u) == 0.5f) ++textured_kept;
      }
    }
  }
  EXPECT_EQ(plain_left, 0) << "plain pixels kept a depth";
  EXPECT_EQ(textured_kept, textured) << "textured pixels lost their depth";
  EXPECT_GE(dropped, (width / 2 - 2) * height);
  EXPECT_EQ(depth.at<float>(5, 30), 0.0f);
}

TEST(StereoDepth, ZeroMinTextureKeepsEveryDepth) {
  const cv::Mat gray = HalfPlainHalfTextured(40, 20);
  cv::Mat depth(20, 40, CV_32F, cv::Scalar(0.5f));
  EXPECT_EQ(DropTexturelessDepths(gray, 0.0, 5, &depth), 0);
  EXPECT_EQ(cv::countNonZero(depth), 40 * 20);
}

TEST(StereoDepth, MismatchedSizesAreAnError) {
  cv::Mat depth(10, 10, CV_32F, cv::Scalar(0.5f));
  EXPECT_ANY_THROW(DropTexturelessDepths(cv::Mat(12, 10, CV_8U, cv::Scalar(0)), 4.0, 5, &depth));
}

}  // namespace
}  // namespace relit::reconstruct
