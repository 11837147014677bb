// Stereo depth post-processing on hand-made images: DropTexturelessDepths
// clears the depths of a plain patch (where SGBM's smoothness term, not a
// match, set them) and keeps those of a textured one; DropDepthsNearFartherEdges
// clears the near side of an occlusion edge (SGBM's fattening).
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

TEST(StereoDepth, DepthsBesideAFartherSurfaceAreDropped) {
  // A near square (0.4 m) on a far background (0.6 m), a hole (unknown) at
  // the left edge: margin 2 clears the near pixels within 2 px of the far
  // ones, keeps the far ones, and an unknown neighbour is no edge.
  cv::Mat depth(20, 20, CV_32F, cv::Scalar(0.6f));
  depth(cv::Rect(5, 5, 10, 10)).setTo(0.4f);
  depth(cv::Rect(0, 0, 2, 20)).setTo(0.0f);
  cv::Mat original = depth.clone();
  const int dropped = DropDepthsNearFartherEdges(2, 0.02, &depth);
  EXPECT_EQ(dropped, 10 * 10 - 6 * 6);  // the square's 2-px rim
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 20; ++u) {
      const bool rim = original.at<float>(v, u) == 0.4f && (u < 7 || u > 12 || v < 7 || v > 12);
      EXPECT_EQ(depth.at<float>(v, u), rim ? 0.0f : original.at<float>(v, u)) << u << "," << v;
    }
  }
  cv::Mat untouched = original.clone();
  EXPECT_EQ(DropDepthsNearFartherEdges(0, 0.02, &untouched), 0);
  EXPECT_EQ(cv::countNonZero(untouched != original), 0);
}

TEST(StereoDepth, MismatchedSizesAreAnError) {
  cv::Mat depth(10, 10, CV_32F, cv::Scalar(0.5f));
  EXPECT_ANY_THROW(DropTexturelessDepths(cv::Mat(12, 10, CV_8U, cv::Scalar(0)), 4.0, 5, &depth));
}

}  // namespace
}  // namespace relit::reconstruct
