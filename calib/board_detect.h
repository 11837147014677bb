// ChArUco board detection: OpenCV 4.6 aruco (detectMarkers with sub-pixel
// corner refinement, refineDetectedMarkers, interpolateCornersCharuco, then
// cv::cornerSubPix on the ChArUco corners) with libapriltag as an optional
// second marker detector for AprilTag dictionaries.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/calib_options.h"
#include "core/board.h"
#include "core/camera.h"

namespace relit::calib {

struct MarkerCorners {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners_px;  // OpenCV order: clockwise from the top-left
};

struct BoardObservation {
  std::vector<int> corner_ids;                 // ChArUco corner ids
  std::vector<Eigen::Vector2d> corners_px;     // distorted pixels, (0,0) = top-left pixel centre
  std::vector<MarkerCorners> markers;          // all markers used (after merging)
  int corners_single_marker = 0;               // corners next to one found marker (detect.min_adjacent_markers 1)
  int markers_opencv = 0;                      // found by OpenCV (incl. refineDetectedMarkers)
  int markers_apriltag = 0;                    // found by libapriltag (when it ran)
  int markers_apriltag_added = 0;              // libapriltag markers OpenCV had missed
  int rejected_candidates = 0;                 // OpenCV quads that did not decode
  bool apriltag_ran = false;
  double opencv_ms = 0;
  double apriltag_ms = 0;
};

class BoardDetector {
 public:
  BoardDetector(const BoardSpec& spec, const DetectOptions& options);
  ~BoardDetector();
  BoardDetector(const BoardDetector&) = delete;
  BoardDetector& operator=(const BoardDetector&) = delete;

  // Thread-safe. `grey` is 8-bit single-channel.
  BoardObservation Detect(const cv::Mat& grey) const;

  // The two marker detectors alone (for benchmarks and tests).
  std::vector<MarkerCorners> DetectOpenCv(const cv::Mat& grey, int* rejected = nullptr) const;
  std::vector<MarkerCorners> DetectAprilTag(const cv::Mat& grey) const;

  // True when the dictionary is an AprilTag family libapriltag knows.
  bool apriltag_available() const;
  int marker_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Contrast (grey levels) of a chessboard corner at `corner_px`: the grey
// values on a circle of `radius_px` around it must form 4 sectors,
// alternately above and below their mean; the result is the mean of the
// bright samples minus the mean of the dark ones, or 0 when the circle does
// not show 4 sectors (an edge, a flat patch, the object in front).
// Saddle-point corner refinement (detect.corner_refine "saddle"): `smooth`
// is the grey image as float smoothed by a Gaussian (SaddleSmoothed); each
// corner moves to the saddle point of the quadratic fitted to the
// (2 half + 1)^2 grid of bilinear samples centred on it, iterated until
// the step is below 0.001 px. A corner whose fit is not a saddle or that
// would end more than `max_move_px` from its start keeps its position (and
// is reported as not converged).
// Exact (up to the fit) for any X-junction whose pattern is point-symmetric
// about the corner within the grid plus blur, whatever the angle between its
// edges and whatever the grey levels.
cv::Mat SaddleSmoothed(const cv::Mat& grey, double sigma_px);
// Returns, per corner, whether it converged (and moved).
std::vector<bool> SaddleRefine(const cv::Mat& smooth, int half, double max_move_px,
                               std::vector<cv::Point2f>* corners);
double XCornerContrast(const cv::Mat& grey, const cv::Point2f& corner_px, double radius_px);

// The libapriltag family name for an OpenCV dictionary name ("tag36h11" for
// "DICT_APRILTAG_36h11"); empty for non-AprilTag dictionaries.
std::string AprilTagFamily(const std::string& dictionary);

// Marker side length divided by square side length, measured in one frame:
// ChArUco corners (undistorted with `intrinsics`) give the board-plane
// homography, detected marker corners are mapped back to the board plane.
// Returns the median over the frame's markers, or a negative number when the
// frame has too few corners or markers.
double MeasureMarkerRatio(const BoardObservation& observation, const Intrinsics& intrinsics,
                          const BoardSpec& spec);

}  // namespace relit::calib
