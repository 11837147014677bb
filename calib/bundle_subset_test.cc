// The joint refinement on key frames, the others placed afterwards
// (calib/bundle_subset.h), and the point budget (KeepLongestTracks).
#include "calib/bundle_subset.h"

#include <algorithm>

#include <gtest/gtest.h>

#include "calib/bundle_test_util.h"

namespace relit::calib {
namespace {

TEST(KeyFramesTest, EvenlySpacedOverThePosedFrames) {
  BundleProblem p;
  p.frames.resize(12);
  for (size_t f = 0; f < p.frames.size(); ++f) p.frames[f].posed = f != 3 && f != 4;
  const std::vector<bool> key = ChooseKeyFrames(p, 5);
  EXPECT_EQ(std::count(key.begin(), key.end(), true), 5);
  EXPECT_TRUE(key[0]);
  EXPECT_FALSE(key[3] || key[4]);  // unposed frames never
  // 10 posed frames, 5 taken: every second one.
  EXPECT_EQ(key, std::vector<bool>({true, false, true, false, false, false, true, false, true, false, true, false}));
  const std::vector<bool> all = ChooseKeyFrames(p, 0);
  EXPECT_EQ(std::count(all.begin(), all.end(), true), 10);
}

TEST(KeyFramesTest, LongestTracksUntilEachFrameHasItsBudget) {
  const Eigen::Vector2d kPx(10, 20);
  std::vector<BundlePoint> points(4);
  points[0].observations = {{0, kPx}, {1, kPx}};
  points[1].observations = {{0, kPx}, {1, kPx}, {2, kPx}};
  points[2].observations = {{1, kPx}, {2, kPx}};
  points[3].observations = {{2, kPx}, {3, kPx}};
  const std::vector<BundlePoint> kept = KeepLongestTracks(points, 4, 1);
  // The 3-frame track first; then only the point that reaches frame 3.
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[0].observations.size(), 3u);
  EXPECT_EQ(kept[1].observations[1].frame, 3);
  std::vector<BundlePoint> dropped;
  EXPECT_EQ(KeepLongestTracks(points, 4, 1, &dropped).size(), 2u);
  ASSERT_EQ(dropped.size(), 2u);  // the two that add nothing new
  EXPECT_EQ(dropped[0].observations[0].frame, 0);
  EXPECT_EQ(dropped[1].observations[0].frame, 1);
  EXPECT_EQ(KeepLongestTracks(points, 4, 0).size(), 4u);
  EXPECT_EQ(KeepLongestTracks(points, 4, 2).size(), 4u);
}

// Half the frames in the joint solve, the other half placed on its lens
// and points: every frame as close to the truth as the full solve puts it.
TEST(KeyFramesTest, PlacedFramesMatchTheFullSolve) {
  std::vector<Rigid3> poses;
  const BundleProblem base = BoardAndPoints(0.1, &poses);
  BundleOptions o;
  o.function_tolerance = 1e-10;
  BundleProblem full = base, half = base;
  SubsetStats subset;
  RefineBundleOnKeyFrames(&full, o, 0, &subset);
  EXPECT_EQ(subset.key_frames, 16);
  EXPECT_EQ(subset.placed_frames, 0);
  const BundleStats stats = RefineBundleOnKeyFrames(&half, o, 8, &subset);
  EXPECT_EQ(subset.key_frames, 8);
  EXPECT_EQ(subset.placed_frames, 8);
  EXPECT_EQ(stats.linear_solver, "DENSE_SCHUR");  // the joint solve's
  EXPECT_LT(stats.corner_rms_px, 0.2);
  EXPECT_NEAR(half.devices["view"].fx, full.devices["view"].fx, 0.5);
  for (int i = 0; i < 16; ++i) {
    ASSERT_TRUE(half.frames[i].posed);
    const Eigen::Vector3d truth = poses[i].Inverse().translation;
    const double full_error = (full.frames[i].cam_from_world.Inverse().translation - truth).norm();
    const double half_error = (half.frames[i].cam_from_world.Inverse().translation - truth).norm();
    EXPECT_LT(half_error, 3e-3) << "frame " << i;                  // the full solve's bound (bundle tests)
    EXPECT_LT(half_error, full_error + 1e-3) << "frame " << i;
    // The start was 5 mm off: placing moved the frame.
    EXPECT_GT((half.frames[i].cam_from_world.translation - base.frames[i].cam_from_world.translation).norm(), 1e-3);
  }
}

}  // namespace
}  // namespace relit::calib
