#include "calib/calib_options.h"

#include <cmath>

#include "core/error.h"
#include "core/log.h"

namespace relit::calib {

RELIT_OPTION_FIELDS(DetectOptions,
    .Add("apriltag", &S::apriltag, {"off", "second_pass", "always"},
         "libapriltag: on frames where OpenCV finds few markers (second_pass) or on all (AprilTag boards only)")
    .Add("apriltag_below_fraction", &S::apriltag_below_fraction, 0.0, 1.0,
         "second_pass runs when OpenCV finds fewer than this share of the board's markers")
    .Add("corner_refine", &S::corner_refine, {"cornersubpix", "saddle"},
         "sub-pixel ChArUco corners: cv::cornerSubPix, or that followed by the saddle point of a quadratic fit")
    .Add("saddle_sigma_px", &S::saddle_sigma_px, 0.3, 5.0, "saddle: Gaussian smoothing before the quadratic fit")
    .Add("saddle_half_window_px", &S::saddle_half_window_px, 1, 10, "saddle: half width of the fitted grid")
    .Add("subpix_half_window_px", &S::subpix_half_window_px, 1, 20, "cornersubpix: cornerSubPix half window")
    .Add("min_corners", &S::min_corners, 4, 10000, "fewer corners: the frame gets no board pose")
    .Add("min_adjacent_markers", &S::min_adjacent_markers, 1, 2,
         "found neighbouring markers a corner needs (1: also corners next to one marker, checked in the image)")
    .Add("single_marker_min_contrast", &S::single_marker_min_contrast, 0.0, 255.0,
         "grey-level contrast a corner next to a single marker must show")
    .Add("threads", &S::threads, 0, 1024, "0 = all cores"))

RELIT_OPTION_FIELDS(IntrinsicsOptions,
    .Add("refine_k3", &S::refine_k3, "refine k3 (poorly constrained on phones)")
    .Add("square_pixels", &S::square_pixels, "fx = fy")
    .Add("refine_tangential", &S::refine_tangential, "refine p1, p2 (they trade off with the principal point)")
    .Add("view_board_images", &S::view_board_images,
         "folder of phone V board-clip frames: its lens is calibrated once and kept fixed (pipeline: inputs)")
    .Add("light_board_images", &S::light_board_images, "the same for phone L (pipeline: inputs)"))

RELIT_OPTION_FIELDS(SfmOptions,
    .Add("enabled", &S::enabled, "false: board poses only (no COLMAP)")
    .Add("mode", &S::mode, {"auto", "incremental", "board_seeded"},
         "COLMAP's incremental mapper (cost superlinear in the images), frames seeded with their board poses "
         "(linear), or auto: board_seeded from auto_seeded_min_images images on")
    .Add("auto_seeded_min_images", &S::auto_seeded_min_images, 1, 100000000,
         "mode auto: images (all devices) from which board_seeded is taken")
    .Add("seed_min_corners", &S::seed_min_corners, 4, 10000, "board corners a frame needs to seed the model")
    .Add("max_features", &S::max_features, 100, 100000, "SIFT features per image")
    .Add("mapper_global_ba_growth", &S::mapper_global_ba_growth, 1.01, 100.0,
         "incremental mapper: a global bundle adjustment each time the model grows by this factor "
         "(COLMAP's Mapper.ba_global_images_ratio and ba_global_points_ratio; COLMAP's default 1.1)")
    .Add("mapper_global_ba_refinements", &S::mapper_global_ba_refinements, 1, 100,
         "incremental mapper: rounds of global bundle adjustment and retriangulation at the end "
         "(COLMAP's Mapper.ba_global_max_refinements; COLMAP's default 5)")
    .Add("first_octave", &S::first_octave, -1, 0,
         "SIFT's first octave: -1 doubles the image first (COLMAP's default), 0 does not (~3x faster, fewer features)")
    .Add("colmap", &S::colmap, "the COLMAP executable")
    .Add("sequential_overlap", &S::sequential_overlap, 1, 1000,
         "neighbours matched in each phone's frame order (incremental)")
    .Add("seeded_overlap", &S::seeded_overlap, 1, 1000, "the same for board_seeded")
    .Add("matcher", &S::matcher, {"opencv", "colmap"},
         "SIFT matching: OpenCV, every descriptor pair by one matrix product, or COLMAP's own (FLANN, ~10x slower "
         "per pair on the CPU; it verifies the pairs itself)")
    .Add("verification", &S::verification, {"opencv", "colmap"},
         "with matcher opencv, each pair's essential-matrix RANSAC: in process on all cores, or by COLMAP's "
         "matches_importer (one core)")
    .Add("ransac_trials", &S::ransac_trials, 10, 1000000, "geometric verification trials per image pair")
    .Add("cross_pair_max_angle_deg", &S::cross_pair_max_angle_deg, 0.0, 180.0,
         "V/L frame pairs matched across phones within this angle")
    .Add("cross_pairs_per_frame", &S::cross_pairs_per_frame, 0, 1000, "cross-phone pairs per frame")
    .Add("min_registered", &S::min_registered, 2, 100000, "fewer registered images: SfM failed")
    .Add("align_inlier_m", &S::align_inlier_m, 1e-5, 10.0, "camera-centre distance for the similarity RANSAC")
    .Add("point_weight", &S::point_weight, 0.0, 100.0, "SfM point residuals relative to board corners")
    .Add("points_per_frame", &S::points_per_frame, 0, 1000000,
         "the joint solve keeps the longest tracks until each frame has this many point observations "
         "(0: every point)")
    .Add("threads", &S::threads, 0, 1024, "0 = all cores")
    .Add("reuse_dir", &S::reuse_dir,
         "a copy of a previous run's calib/sfm folder: its COLMAP model is read, no COLMAP step runs "
         "(benchmarks of the refinement; same capture only)"))

void SfmOptions::Check() const {
  RELIT_REQUIRE(!colmap.empty(), "colmap (the COLMAP executable) must not be empty");
}

RELIT_OPTION_FIELDS(RefineOptions,
    .Add("huber_px", &S::huber_px, 1e-3, 100.0, "robust loss scale")
    .Add("outlier_px", &S::outlier_px, 0.1, 1000.0, "observations beyond this are dropped, then solved again")
    .Add("final_huber_px", &S::final_huber_px, 0.0, 1000.0,
         "robust loss scale of that second solve (0: huber_px)")
    .Add("max_iterations", &S::max_iterations, 1, 100000, "Ceres iterations")
    .Add("linear_solver", &S::linear_solver, {"auto", "dense_schur", "sparse_schur", "iterative_schur"},
         "Ceres linear solver (auto: dense Schur with SfM points up to dense_schur_max_frames frames, "
         "iterative Schur above, sparse Schur on board corners alone; iterative_schur applies with SfM points)")
    .Add("dense_schur_max_frames", &S::dense_schur_max_frames, 0, 1000000,
         "auto's switch from dense to iterative Schur (sparse Schur above it until 2026-11-27)")
    .Add("max_joint_frames", &S::max_joint_frames, 0, 100000000,
         "the joint solve's frames at most, evenly spaced (0: all); the others are then placed one by one on "
         "its lenses and points")
    .Add("iterative_eta", &S::iterative_eta, 1e-6, 0.9,
         "iterative Schur's forcing term (Ceres' eta): conjugate gradients stop at this relative residual")
    .Add("dense_library", &S::dense_library, {"auto", "eigen", "lapack"},
         "dense Schur's Cholesky (auto: LAPACK when it is OpenBLAS, 2-5x faster than Ceres' Eigen; else Eigen)")
    .Add("function_tolerance", &S::function_tolerance, 1e-16, 0.1,
         "Ceres stops when the cost changes by less than this fraction")
    .Add("first_function_tolerance", &S::first_function_tolerance, 0.0, 0.1,
         "the same for the first solve, before outliers are dropped (0: function_tolerance)")
    .Add("first_max_iterations", &S::first_max_iterations, 0, 100000,
         "iterations of that first solve at most (0: max_iterations)")
    .Add("rolling_shutter", &S::rolling_shutter,
         "model each video's rolling shutter: refine its readout time, each frame's motion from its neighbours")
    .Add("rolling_shutter_max_gap_s", &S::rolling_shutter_max_gap_s, 1e-4, 10.0,
         "neighbours further apart in time give a frame no motion (read as a global shutter)")
    .Add("max_readout_s", &S::max_readout_s, 1e-4, 1.0, "the readout time's upper bound, first to last row")
    .Add("max_corner_rms_px", &S::max_corner_rms_px, 0.01, 1000.0, "board-corner RMS above this: rejected")
    .Add("max_ratio_error", &S::max_ratio_error, 0.001, 1.0,
         "|measured / specified marker-to-square ratio - 1| above this: rejected"))

RELIT_OPTION_FIELDS(LightOptions,
    .Add("flash_offset_m", &S::flash_offset_m, "flash position [x, y, z] in phone L's camera frame, metres")
    .Add("max_gap_s", &S::max_gap_s, 1e-6, 10.0, "nearest registered phone L frame further: unreliable"))

void LightOptions::Check() const {
  RELIT_REQUIRE(flash_offset_m.size() == 3, "flash_offset_m must be [x, y, z] in metres, got ",
                flash_offset_m.size(), " numbers");
  for (double v : flash_offset_m) {
    RELIT_REQUIRE(std::isfinite(v) && std::abs(v) < 1.0, "flash_offset_m entries must be below 1 m, got ", v);
  }
}

std::vector<std::string> UndistortInterpolationNames() { return {"cubic", "lanczos4", "linear"}; }

RELIT_OPTION_FIELDS(UndistortOptions,
    .Add("alpha", &S::alpha, 0.0, 1.0,
         "0: only valid pixels (crops), 1: every source pixel (black borders)")
    .Add("interpolation", &S::interpolation, UndistortInterpolationNames(),
         "resampling of the undistorted frames; bilinear blurs them by up to half a pixel")
    .Add("write_images", &S::write_images, "write the undistorted frames"))

RELIT_OPTION_FIELDS(CalibOptions,
    .Add("workspace", &S::workspace, "W: reads W/capture, writes W/calib (`--workspace`)")
    .Section("board", &S::board)
    .Section("detect", &S::detect)
    .Section("intrinsics", &S::intrinsics)
    .Section("sfm", &S::sfm)
    .Section("refine", &S::refine)
    .Section("light", &S::light)
    .Section("undistort", &S::undistort)
    .Add("log_level", &S::log_level, LogLevelNames(), "what the stage prints (`--log-level`)"))

void CalibOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "no workspace: pass --workspace W (reads W/capture, writes W/calib)");
}

}  // namespace relit::calib
