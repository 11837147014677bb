// Options of the calib stage (relit-calib): the printed board, detection,
// intrinsics, COLMAP structure from motion, the joint refinement, light
// interpolation and undistortion. Defaults live here; the field tables
// (calib_options.cc) read the YAML file (unknown keys are errors),
// command-line flags go on top, then CheckOptions(). docs/calib.md's table is
// generated from the field tables (tools/options_doc).
#pragma once

#include <string>
#include <vector>

#include "core/board.h"
#include "core/option_fields.h"

namespace relit::calib {

struct DetectOptions {
  // libapriltag use: "off", "second_pass" (frames where OpenCV finds fewer
  // than apriltag_below_fraction of the board's markers) or "always" (both
  // detectors on every frame, markers merged). Only for AprilTag
  // dictionaries; ignored (with a note) for ArUco ones.
  std::string apriltag = "second_pass";
  double apriltag_below_fraction = 0.8;
  // Sub-pixel refinement of the ChArUco corners: "cornersubpix" is
  // cv::cornerSubPix with subpix_half_window_px; "saddle" follows it with a
  // quadratic fitted to the image smoothed by a Gaussian of saddle_sigma_px
  // over a (2 saddle_half_window_px + 1)^2 grid centred on the corner, and
  // moves to its saddle point (Lucchese & Mitra 2002). saddle halves the
  // corner error on the demo capture but did not improve its calibration
  // (docs/notes/calib-at-scale-2026-11-27c.md): not the default.
  std::string corner_refine = "cornersubpix";
  double saddle_sigma_px = 1.0;
  int saddle_half_window_px = 2;
  int subpix_half_window_px = 3;   // cv::cornerSubPix half window on ChArUco corners
  int min_corners = 6;             // fewer corners: the frame gets no board pose
  // A ChArUco corner needs this many of its two neighbouring markers found
  // (OpenCV: 2). With 1, a frame with fewer than min_corners such corners
  // also gets the corners next to a single found marker, where the image
  // shows a chessboard corner (4 light/dark sectors of at least
  // single_marker_min_contrast grey levels on a 3 px circle) and
  // cornerSubPix keeps them within 1.5 px: a flash shadow or the object
  // hiding half the board leaves a marker's other neighbour unreadable.
  int min_adjacent_markers = 1;
  double single_marker_min_contrast = 20;
  int threads = 0;                 // 0 = all cores

  static const OptionFields<DetectOptions>& Fields();
};

struct IntrinsicsOptions {
  bool refine_k3 = false;          // k3 stays 0 unless set (poorly constrained on phones)
  bool square_pixels = true;       // fx = fy (phone sensors have square pixels)
  bool refine_tangential = false;  // p1, p2 stay 0 unless set (they trade off with the principal point)
  // Optional folders of board images (e.g. frames of a board clip) per
  // device; when given, the device's intrinsics come from
  // calibrateCameraCharuco on them and stay fixed in the refinement.
  std::string view_board_images;
  std::string light_board_images;

  static const OptionFields<IntrinsicsOptions>& Fields();
};

struct SfmOptions {
  bool enabled = true;             // false: board poses only (no COLMAP)
  // "incremental": COLMAP's incremental mapper from scratch, then aligned
  // to the board (its cost grows faster than linearly with the images);
  // "board_seeded": frames with a good board pose enter COLMAP with that
  // pose (point_triangulator), image_registrator places the rest (linear:
  // 990 images at 640x480 in 8:44 on 2 cores, cameras 0.87-0.97 mm from
  // truth); "auto" (default): board_seeded from auto_seeded_min_images
  // images on, when at least two frames can seed it, else incremental
  // (docs/calib.md step 5).
  std::string mode = "auto";
  int auto_seeded_min_images = 500;
  int seed_min_corners = 6;        // board corners a frame needs to seed the model with its pose
  int max_features = 8192;         // SIFT features per image (COLMAP's default)
  int first_octave = -1;           // SIFT's first octave (-1: image doubled first, COLMAP's default)
  // The incremental mapper's global bundle adjustment runs each time the
  // model has grown by this factor in images or points (COLMAP's default
  // 1.1): on the demo's 350 images it took 198 of the mapper's 245 s, and
  // the joint Ceres solve refines every pose and point afterwards anyway.
  double mapper_global_ba_growth = 1.4;
  int mapper_global_ba_refinements = 2;  // final global BA + retriangulation rounds (COLMAP's default 5)
  std::string colmap = "colmap";   // the COLMAP executable
  int sequential_overlap = 10;     // neighbours matched in each phone's frame order (incremental)
  // The same for board_seeded: the board poses tie the model together, so
  // fewer neighbours suffice (matching is most of COLMAP's time).
  int seeded_overlap = 3;
  // "opencv": descriptors matched by OpenCV (calib/feature_matching.h);
  // "colmap": COLMAP 3.8's CPU matcher (FLANN trees built again per pair:
  // ~10x slower; docs/calib.md step 5), which verifies the pairs itself.
  std::string matcher = "opencv";
  // With matcher opencv, the pairs' geometric verification: "opencv" in
  // process on all cores (calib/pair_verification.h), "colmap" by COLMAP's
  // matches_importer (one core, ~10 ms per pair).
  std::string verification = "opencv";
  int ransac_trials = 1000;        // COLMAP geometric verification trials per image pair
  double cross_pair_max_angle_deg = 35.0;  // V/L frame pairs matched across phones
  int cross_pairs_per_frame = 4;
  int min_registered = 6;          // fewer registered images: SfM failed
  double align_inlier_m = 0.02;    // camera-centre distance for the similarity RANSAC
  double point_weight = 0.5;       // SfM point residuals relative to board corners
  // The joint solve keeps the longest tracks until each frame has this many
  // point observations (0: every point): its time follows the observations
  // (1.3 million at 3,000 images).
  int points_per_frame = 200;
  int threads = 0;                 // 0 = all cores
  // A previous run's calib/sfm folder (copied out of W/calib, which each run
  // replaces): its COLMAP model is read and no COLMAP step runs. For
  // measuring the refinement alone on the same capture.
  std::string reuse_dir;

  static const OptionFields<SfmOptions>& Fields();
  void Check() const;  // the COLMAP executable is named
};

struct RefineOptions {
  double huber_px = 1.0;           // robust loss scale
  double outlier_px = 3.0;         // observations beyond this are dropped, then solved again
  // Huber scale of that second solve (0: huber_px). At outlier_px (3)
  // every inlier is quadratic and Gauss-Newton converges in ~6 iterations
  // instead of ~25, but phone L ended 0.5 mm further from truth at ~400
  // images (docs/notes/calib-at-scale-2026-11-26.md).
  double final_huber_px = 0;
  int max_iterations = 100;
  // Ceres linear solver: "auto" (dense Schur up to dense_schur_max_frames
  // frames, iterative Schur above), "dense_schur", "sparse_schur" or
  // "iterative_schur" (conjugate gradients, Schur-Jacobi preconditioner).
  std::string linear_solver = "auto";
  // With SfM points, dense Schur took 79 s against sparse 143 s at 312
  // frames and 1,046 s against 1,474 s at 990 frames (same model, side by
  // side, the same result): the reduced camera system is nearly dense
  // (lenses, long tracks, cross pairs). Board corners alone always take
  // sparse Schur under auto (docs/notes/calib-at-scale-2026-11-27.md).
  int dense_schur_max_frames = 1000;
  // The joint solve takes at most this many frames, evenly spaced (0: all);
  // the others are placed afterwards on its lenses and points, one frame
  // at a time (calib/bundle_subset.h).
  int max_joint_frames = 1000;
  // Iterative Schur's forcing term (Ceres' eta: conjugate gradients stop at
  // this relative residual). At 990 frames 0.1 (Ceres' default) stopped
  // 0.2 mm short of dense Schur along the flat focal-distance direction,
  // 1e-2 reached it in 2.3x the time (docs/notes/calib-at-scale-2026-11-27e.md).
  double iterative_eta = 0.01;
  // Dense Schur's Cholesky: "auto" (LAPACK when it is OpenBLAS, else
  // Ceres' Eigen), "eigen" or "lapack" (calib/bundle.cc DenseLibrary).
  std::string dense_library = "auto";
  // Ceres stops when the cost changes by less than this fraction. At ~400
  // images 1e-6 (30 iterations in all) placed every device as 1e-9 did
  // (100 + 100 iterations, unconverged); at 990 images 1e-5 placed them as
  // 1e-6 did on two COLMAP models, in 292 s against 623 and 439 s against
  // 499 (docs/notes/calib-at-scale-2026-11-27e.md).
  double function_tolerance = 1e-5;
  // The same for the first solve, which only has to bring the outliers out
  // (0: function_tolerance): 1e-4 took 6 iterations instead of 100.
  double first_function_tolerance = 1e-4;
  // The first solve's iteration cap (0: max_iterations). At 990 frames the
  // first solve took 18 iterations to 1e-4 (6 at ~300 frames).
  int first_max_iterations = 0;
  // Rolling shutter (calib/rolling_shutter.h): the second solve refines
  // each video's readout time within [0, max_readout_s], each frame's motion
  // read from its neighbours at most rolling_shutter_max_gap_s away.
  // Off by default: on the synthetic captures (1 ms readouts) it bought
  // nothing at 990 images and on the tiny capture's 19 board-only frames it
  // read phone V's readout as 6.8 ms and moved phone V from 4.7 to 8.1 mm
  // (docs/notes/calib-at-scale-2026-11-27d.md). For phones with long
  // readouts filmed with enough frames.
  bool rolling_shutter = false;
  double rolling_shutter_max_gap_s = 0.1;
  double max_readout_s = 0.05;
  double max_corner_rms_px = 1.0;  // board-corner RMS above this: calibration rejected
  double max_ratio_error = 0.04;   // |measured/specified marker-to-square ratio - 1|

  static const OptionFields<RefineOptions>& Fields();
};

struct LightOptions {
  std::vector<double> flash_offset_m = {0.01, 0.0, 0.0};  // in phone L's camera frame
  double max_gap_s = 0.05;         // nearest registered L frame further: unreliable

  static const OptionFields<LightOptions>& Fields();
  void Check() const;  // flash_offset_m has 3 entries below 1 m
};

// UndistortOptions::interpolation's values (undistort.h maps them to OpenCV's).
std::vector<std::string> UndistortInterpolationNames();

struct UndistortOptions {
  // 0: the pinhole image only holds valid pixels (crops), 1: keeps every
  // source pixel (black borders). cv::getOptimalNewCameraMatrix's alpha.
  double alpha = 0.0;
  // How the frames are resampled: "cubic" (default), "lanczos4" or
  // "linear". Bilinear blurs by the fractional part of every source
  // position (a variance of 1/6 px^2 on average), which the relit asset
  // would learn as the object's own softness.
  std::string interpolation = "cubic";
  bool write_images = true;

  static const OptionFields<UndistortOptions>& Fields();
};

struct CalibOptions {
  std::string workspace;           // reads W/capture, writes W/calib
  BoardSpec board;
  DetectOptions detect;
  IntrinsicsOptions intrinsics;
  SfmOptions sfm;
  RefineOptions refine;
  LightOptions light;
  UndistortOptions undistort;
  std::string log_level = "info";
  // --force: replace an output folder that relit did not write (never one
  // holding an input, never a file). Not an option of the config file.
  bool force = false;

  static const OptionFields<CalibOptions>& Fields();
  void Check() const;  // the workspace is given; ranges: CheckOptions
};

}  // namespace relit::calib
