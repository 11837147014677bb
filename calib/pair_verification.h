// Geometric verification of matched SIFT pairs, in process (issue 28).
// COLMAP 3.8's `matches_importer --match_type raw` verifies given matches on
// one thread (10.7 ms per pair: 53 s of a 990-image capture's 5,046 pairs).
// Here each pair's matches are checked against an essential matrix found by
// RANSAC (OpenCV's five-point solver) on keypoints undistorted with the
// board-calibrated lenses, under COLMAP's criteria (Sampson error ≤ 4 px at
// the mean focal length, ≥ 15 inliers), in parallel over pairs; the matches
// and the verified pairs go into COLMAP's database as its own verification
// would write them (the schema of COLMAP's scripts/python/database.py).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "calib/feature_matching.h"
#include "core/camera.h"

namespace relit::calib {

struct PairVerificationOptions {
  double max_error_px = 4.0;    // Sampson error of an inlier (COLMAP's SiftMatching.max_error)
  int min_inliers = 15;         // fewer: the pair is not verified (COLMAP's min_num_inliers)
  double confidence = 0.999;    // RANSAC stop (COLMAP's SiftMatching.confidence)
  int max_trials = 1000;        // RANSAC samples at most (COLMAP's max_num_trials)
  int threads = 0;              // 0 = all cores
};

struct PairVerificationStats {
  int pairs = 0;
  int verified_pairs = 0;
  long matches = 0;   // descriptor matches in
  long inliers = 0;   // matches of verified pairs out
  double seconds = 0;
};

// The inlier matches (indices into `matches`) of one pair, given the matched
// keypoints as normalised camera coordinates (undistorted, (x - cx) / fx).
// `max_error` is in the same normalised units. Empty when fewer than
// min_inliers agree on one essential matrix.
std::vector<int> EssentialInliers(const std::vector<Eigen::Vector2d>& normalized_a,
                                  const std::vector<Eigen::Vector2d>& normalized_b,
                                  const std::vector<std::pair<int, int>>& matches, double max_error,
                                  const PairVerificationOptions& options);

// Verifies every matched pair and writes them to the COLMAP database that
// holds their keypoints: table `matches` (all descriptor matches) and
// `two_view_geometries` (the inliers, config CALIBRATED; unverified pairs
// with no rows, config DEGENERATE), replacing rows of the same pairs.
// `lens_of_image` gives each image's lens (the one its features were
// extracted with).
PairVerificationStats VerifyAndStorePairs(const std::string& database, const MatchedPairs& matched,
                                          const std::map<std::string, Intrinsics>& lens_of_image,
                                          const PairVerificationOptions& options);

}  // namespace relit::calib
