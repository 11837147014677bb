// SIFT descriptor matching for the COLMAP run, on the CPU (issue 28).
// Debian's COLMAP 3.8 matches on the CPU through FLANN kd-trees that it
// builds again for every image pair: ~45 ms of wall time per pair of ~700
// features on 2 cores, 60 % of COLMAP's time on a 1,000-image capture.
// Here one matrix product (OpenCV's gemm) gives all descriptor angles of a
// pair, and COLMAP's criteria are applied to it: ratio test and maximum
// angle, mutual best match. The pairs are then verified geometrically
// (calib/pair_verification.h, or COLMAP's `matches_importer --match_type
// raw` from the raw match file written here).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace relit::calib {

using ImagePairs = std::vector<std::pair<std::string, std::string>>;

// The pairs COLMAP 3.8's sequential matcher forms over images sorted by
// name: each image with the next overlap - 1 and with those 2^k further on
// (k < overlap, its "quadratic overlap"); no pair twice.
ImagePairs SequentialPairs(std::vector<std::string> names, int overlap);

struct DescriptorMatchOptions {
  double max_ratio = 0.8;     // best / second-best descriptor angle (COLMAP's SiftMatching.max_ratio)
  double max_angle = 0.7;     // radians between matched descriptors (COLMAP's SiftMatching.max_distance)
  bool cross_check = true;    // keep mutual best matches only
  int threads = 0;            // 0 = all cores
};

struct DescriptorMatchStats {
  int pairs = 0;                      // pairs matched
  int pairs_without_descriptors = 0;  // pairs left out: an image has no descriptors
  long matches = 0;
  double seconds = 0;
};

// Matched image pairs: matches[i] holds (keypoint index in pairs[i].first,
// keypoint index in pairs[i].second).
struct MatchedPairs {
  ImagePairs pairs;
  std::vector<std::vector<std::pair<int, int>>> matches;
};

// Matches the descriptors that COLMAP's feature_extractor stored in
// `database` for every pair (image names). Pairs with an image that has no
// descriptors in the database are left out (counted in stats).
MatchedPairs MatchDescriptors(const std::string& database, const ImagePairs& pairs,
                              const DescriptorMatchOptions& options, DescriptorMatchStats* stats);

// Writes matched pairs in matches_importer's raw format: per pair a line
// with the two names, one "index1 index2" line per match and an empty line.
void WriteRawMatches(const MatchedPairs& matched, const std::string& raw_path);

}  // namespace relit::calib
