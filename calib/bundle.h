// The joint refinement (Ceres): camera poses of every frame, the lens of
// each device (fx, fy, cx, cy, k1, k2, p1, p2 and optionally k3), SfM points,
// with ChArUco corner observations at their known world positions (which fix
// the metric world frame) and SfM point observations, under a Huber loss.
// Observations beyond an outlier threshold are dropped and the problem is
// solved again.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rolling_shutter.h"
#include "core/camera.h"

namespace relit::calib {

struct PointObservation {
  int frame = 0;               // index into BundleProblem::frames
  Eigen::Vector2d pixel_px;    // distorted pixels, OpenCV convention
};

struct BundlePoint {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();   // world
  std::vector<PointObservation> observations;
};

struct BundleFrame {
  std::string device;
  bool posed = false;                    // has an initial pose: takes part in the problem
  Rigid3 cam_from_world;
  std::vector<int> corner_ids;           // ChArUco corners seen
  std::vector<Eigen::Vector2d> corners_px;
  // Rolling shutter (calib/rolling_shutter.h): frames of one video share a
  // clock and a readout time; "" = a still photo, read as a global shutter.
  std::string video;
  double time_s = 0;                     // the middle row's time on the video's clock
  int rotation_deg = 0;                  // the video's display rotation (ReadoutFraction)
};

struct BundleProblem {
  std::vector<Eigen::Vector3d> corners_world;   // CharucoCornersWorld
  std::map<std::string, Intrinsics> devices;
  std::map<std::string, bool> fixed_lens;       // device -> keep intrinsics constant
  bool refine_k3 = false;
  bool square_pixels = false;                   // fy tied to fx
  bool refine_tangential = true;                // false: p1, p2 held
  std::vector<BundleFrame> frames;
  std::vector<BundlePoint> points;
  bool fixed_points = false;                    // points held at their positions (frames placed on them)
  // SfM points left out of the solve (sfm.points_per_frame), at their
  // aligned COLMAP positions: exported with the model, never refined.
  std::vector<Eigen::Vector3d> unrefined_points_m;
};

struct BundleOptions {
  double huber_px = 1.0;        // first solve: robust to the outliers still present
  double outlier_px = 3.0;
  // Second solve, after the outliers are dropped (0: huber_px). At
  // outlier_px every inlier sits in Huber's quadratic part: Gauss-Newton then
  // converges quadratically instead of re-weighting for 100 iterations.
  double final_huber_px = 0;
  double point_weight = 0.5;
  int max_iterations = 100;
  int threads = 0;
  std::string linear_solver = "auto";  // auto | dense_schur | sparse_schur | iterative_schur
  int dense_schur_max_frames = 1000;   // auto: dense Schur with points up to this many posed frames (calib's refine.*)
  double iterative_eta = 0.01;         // iterative Schur's forcing term (Ceres' eta; calib's refine.*)
  double function_tolerance = 1e-6;
  std::string dense_library = "auto";  // auto | eigen | lapack: dense Schur's Cholesky (calib's refine.*)
  // First solve (0: function_tolerance): it only has to bring the outliers
  // out for the second solve to drop.
  double first_function_tolerance = 0;
  int first_max_iterations = 0;  // the first solve's iteration cap (0: max_iterations)
  // The second solve models each video's rolling shutter: its readout time
  // is refined within [0, max_readout_s], each frame's motion read from its
  // neighbours at most rolling_shutter_max_gap_s away.
  bool rolling_shutter = false;
  double rolling_shutter_max_gap_s = 0.1;
  double max_readout_s = 0.05;
};

struct BundleStats {
  double corner_rms_px = 0;              // board corners (inliers)
  double point_rms_px = 0;               // SfM points (inliers)
  int corner_observations = 0, point_observations = 0;
  int corner_outliers = 0, point_outliers = 0;
  std::map<std::string, double> corner_rms_px_by_device;
  std::vector<double> frame_corner_rms_px;   // per frame (0 without corners)
  int iterations = 0;                    // both solves
  int final_iterations = 0;              // the second solve
  double initial_cost = 0, final_cost = 0;
  std::string linear_solver;             // the one Ceres used
  std::string dense_library;             // EIGEN or LAPACK under dense Schur, else ""
  double solve_s = 0;                    // both Ceres solves, wall time
  std::map<std::string, double> readout_s;  // per video with a rolling shutter refined
  std::map<std::string, int> moving_frames;  // per video: frames whose motion was known
};

// Refines `problem` in place. Frames with posed = false are left out; a
// frame whose observations all turn out to be outliers loses its pose
// (posed = false afterwards).
BundleStats RefineBundle(BundleProblem* problem, const BundleOptions& options);

// The longest tracks first, each kept while one of its frames has fewer than
// `per_frame` point observations (0: every point); the others go to
// `dropped` when given. The joint solve's time follows the point
// observations; what they buy is the frames they tie.
std::vector<BundlePoint> KeepLongestTracks(std::vector<BundlePoint> points, size_t frames, int per_frame,
                                           std::vector<BundlePoint>* dropped = nullptr);

// Reprojection residual statistics without refining (for reports).
BundleStats EvaluateBundle(const BundleProblem& problem, double outlier_px);

}  // namespace relit::calib
