#include "calib/calib_options.h"

#include <cmath>

#include "core/error.h"
#include "core/workspace.h"

namespace relit::calib {

void DetectOptions::Read(OptionsReader& r) {
  r.Read("apriltag", &apriltag);
  r.ReadRange("apriltag_below_fraction", &apriltag_below_fraction, 0.0, 1.0);
  r.ReadRange("subpix_half_window_px", &subpix_half_window_px, 1, 20);
  r.ReadRange("min_corners", &min_corners, 4, 10000);
  r.ReadRange("min_adjacent_markers", &min_adjacent_markers, 1, 2);
  r.ReadRange("single_marker_min_contrast", &single_marker_min_contrast, 0.0, 255.0);
  r.ReadRange("threads", &threads, 0, 1024);
  r.Finish();
}

void DetectOptions::Check() const {
  RELIT_REQUIRE(apriltag == "off" || apriltag == "second_pass" || apriltag == "always",
                "detect.apriltag must be off, second_pass or always, got '", apriltag, "'");
  RELIT_REQUIRE(apriltag_below_fraction >= 0 && apriltag_below_fraction <= 1,
                "detect.apriltag_below_fraction must be in [0, 1], got ", apriltag_below_fraction);
  RELIT_REQUIRE(subpix_half_window_px >= 1, "detect.subpix_half_window_px must be >= 1");
  RELIT_REQUIRE(min_corners >= 4, "detect.min_corners must be >= 4 (PnP), got ", min_corners);
  RELIT_REQUIRE(threads >= 0, "detect.threads must be >= 0");
  RELIT_REQUIRE(min_adjacent_markers == 1 || min_adjacent_markers == 2,
                "detect.min_adjacent_markers must be 1 or 2, got ", min_adjacent_markers);
  RELIT_REQUIRE(single_marker_min_contrast >= 0 && single_marker_min_contrast <= 255,
                "detect.single_marker_min_contrast must be in [0, 255] grey levels, got ",
                single_marker_min_contrast);
}

nlohmann::json DetectOptions::ToJson() const {
  return {{"apriltag", apriltag},
          {"apriltag_below_fraction", apriltag_below_fraction},
          {"subpix_half_window_px", subpix_half_window_px},
          {"min_corners", min_corners},
          {"min_adjacent_markers", min_adjacent_markers},
          {"single_marker_min_contrast", single_marker_min_contrast},
          {"threads", threads}};
}

void IntrinsicsOptions::Read(OptionsReader& r) {
  r.Read("refine_k3", &refine_k3);
  r.Read("square_pixels", &square_pixels);
  r.Read("refine_tangential", &refine_tangential);
  r.Read("view_board_images", &view_board_images);
  r.Read("light_board_images", &light_board_images);
  r.Finish();
}

void IntrinsicsOptions::Check() const {}

nlohmann::json IntrinsicsOptions::ToJson() const {
  return {{"refine_k3", refine_k3},
          {"square_pixels", square_pixels},
          {"refine_tangential", refine_tangential},
          {"view_board_images", view_board_images},
          {"light_board_images", light_board_images}};
}

void SfmOptions::Read(OptionsReader& r) {
  r.Read("enabled", &enabled);
  r.Read("mode", &mode);
  r.ReadRange("seed_min_corners", &seed_min_corners, 4, 10000);
  r.ReadRange("max_features", &max_features, 100, 100000);
  r.Read("colmap", &colmap);
  r.ReadRange("sequential_overlap", &sequential_overlap, 1, 1000);
  r.ReadRange("seeded_overlap", &seeded_overlap, 1, 1000);
  r.ReadRange("ransac_trials", &ransac_trials, 10, 1000000);
  r.ReadRange("cross_pair_max_angle_deg", &cross_pair_max_angle_deg, 0.0, 180.0);
  r.ReadRange("cross_pairs_per_frame", &cross_pairs_per_frame, 0, 1000);
  r.ReadRange("min_registered", &min_registered, 2, 100000);
  r.ReadRange("align_inlier_m", &align_inlier_m, 1e-5, 10.0);
  r.ReadRange("point_weight", &point_weight, 0.0, 100.0);
  r.ReadRange("threads", &threads, 0, 1024);
  r.Finish();
}

void SfmOptions::Check() const {
  RELIT_REQUIRE(mode == "board_seeded" || mode == "incremental",
                "sfm.mode must be board_seeded or incremental, got '", mode, "'");
  RELIT_REQUIRE(seed_min_corners >= 4, "sfm.seed_min_corners must be >= 4 (PnP), got ", seed_min_corners);
  RELIT_REQUIRE(max_features >= 100, "sfm.max_features must be >= 100, got ", max_features);
  RELIT_REQUIRE(!colmap.empty(), "sfm.colmap (the COLMAP executable) must not be empty");
  RELIT_REQUIRE(sequential_overlap >= 1 && seeded_overlap >= 1,
                "sfm.sequential_overlap and sfm.seeded_overlap must be >= 1");
  RELIT_REQUIRE(ransac_trials >= 10, "sfm.ransac_trials must be >= 10");
  RELIT_REQUIRE(min_registered >= 2, "sfm.min_registered must be >= 2");
  RELIT_REQUIRE(align_inlier_m > 0, "sfm.align_inlier_m must be positive");
  RELIT_REQUIRE(point_weight >= 0, "sfm.point_weight must be >= 0");
}

nlohmann::json SfmOptions::ToJson() const {
  return {{"enabled", enabled},
          {"mode", mode},
          {"seed_min_corners", seed_min_corners},
          {"max_features", max_features},
          {"colmap", colmap},
          {"sequential_overlap", sequential_overlap},
          {"seeded_overlap", seeded_overlap},
          {"ransac_trials", ransac_trials},
          {"cross_pair_max_angle_deg", cross_pair_max_angle_deg},
          {"cross_pairs_per_frame", cross_pairs_per_frame},
          {"min_registered", min_registered},
          {"align_inlier_m", align_inlier_m},
          {"point_weight", point_weight},
          {"threads", threads}};
}

void RefineOptions::Read(OptionsReader& r) {
  r.ReadRange("huber_px", &huber_px, 1e-3, 100.0);
  r.ReadRange("outlier_px", &outlier_px, 0.1, 1000.0);
  r.ReadRange("max_iterations", &max_iterations, 1, 100000);
  r.Read("linear_solver", &linear_solver);
  r.ReadRange("dense_schur_max_frames", &dense_schur_max_frames, 0, 1000000);
  r.ReadRange("function_tolerance", &function_tolerance, 1e-16, 0.1);
  r.ReadRange("max_corner_rms_px", &max_corner_rms_px, 0.01, 1000.0);
  r.ReadRange("max_ratio_error", &max_ratio_error, 0.001, 1.0);
  r.Finish();
}

void RefineOptions::Check() const {
  RELIT_REQUIRE(huber_px > 0 && outlier_px > 0, "refine.huber_px and refine.outlier_px must be positive");
  RELIT_REQUIRE(max_iterations >= 1, "refine.max_iterations must be >= 1");
  RELIT_REQUIRE(linear_solver == "auto" || linear_solver == "dense_schur" || linear_solver == "sparse_schur" ||
                    linear_solver == "iterative_schur",
                "refine.linear_solver must be auto, dense_schur, sparse_schur or iterative_schur, got '",
                linear_solver, "'");
  RELIT_REQUIRE(dense_schur_max_frames >= 0, "refine.dense_schur_max_frames must be >= 0");
  RELIT_REQUIRE(function_tolerance > 0 && function_tolerance < 0.1,
                "refine.function_tolerance must be in (0, 0.1), got ", function_tolerance);
  RELIT_REQUIRE(max_corner_rms_px > 0, "refine.max_corner_rms_px must be positive");
  RELIT_REQUIRE(max_ratio_error > 0, "refine.max_ratio_error must be positive");
}

nlohmann::json RefineOptions::ToJson() const {
  return {{"huber_px", huber_px},
          {"outlier_px", outlier_px},
          {"max_iterations", max_iterations},
          {"linear_solver", linear_solver},
          {"dense_schur_max_frames", dense_schur_max_frames},
          {"function_tolerance", function_tolerance},
          {"max_corner_rms_px", max_corner_rms_px},
          {"max_ratio_error", max_ratio_error}};
}

void LightOptions::Read(OptionsReader& r) {
  r.Read("flash_offset_m", &flash_offset_m);
  r.ReadRange("max_gap_s", &max_gap_s, 0.0, 10.0);
  r.Finish();
}

void LightOptions::Check() const {
  RELIT_REQUIRE(flash_offset_m.size() == 3, "light.flash_offset_m must be [x, y, z] in metres, got ",
                flash_offset_m.size(), " numbers");
  for (double v : flash_offset_m) {
    RELIT_REQUIRE(std::isfinite(v) && std::abs(v) < 1.0,
                  "light.flash_offset_m entries must be below 1 m, got ", v);
  }
  RELIT_REQUIRE(max_gap_s > 0, "light.max_gap_s must be positive");
}

nlohmann::json LightOptions::ToJson() const {
  return {{"flash_offset_m", flash_offset_m}, {"max_gap_s", max_gap_s}};
}

void UndistortOptions::Read(OptionsReader& r) {
  r.ReadRange("alpha", &alpha, 0.0, 1.0);
  r.Read("write_images", &write_images);
  r.Finish();
}

void UndistortOptions::Check() const {
  RELIT_REQUIRE(alpha >= 0 && alpha <= 1, "undistort.alpha must be in [0, 1], got ", alpha);
}

nlohmann::json UndistortOptions::ToJson() const {
  return {{"alpha", alpha}, {"write_images", write_images}};
}

void CalibOptions::Read(OptionsReader& r) {
  r.Read("workspace", &workspace);
  OptionsReader board_reader = r.Child("board");
  ReadBoardSpec(board_reader, &board);
  OptionsReader d = r.Child("detect");
  detect.Read(d);
  OptionsReader i = r.Child("intrinsics");
  intrinsics.Read(i);
  OptionsReader s = r.Child("sfm");
  sfm.Read(s);
  OptionsReader f = r.Child("refine");
  refine.Read(f);
  OptionsReader l = r.Child("light");
  light.Read(l);
  OptionsReader u = r.Child("undistort");
  undistort.Read(u);
  r.Read("log_level", &log_level);
  r.Finish();
}

void CalibOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "no workspace: pass --workspace W (reads W/capture, writes W/calib)");
  board.Check();
  detect.Check();
  intrinsics.Check();
  sfm.Check();
  refine.Check();
  light.Check();
  undistort.Check();
}

nlohmann::json CalibOptions::ToJson() const {
  return {{"workspace", workspace},
          {"board", relit::ToJson(board)},
          {"detect", detect.ToJson()},
          {"intrinsics", intrinsics.ToJson()},
          {"sfm", sfm.ToJson()},
          {"refine", refine.ToJson()},
          {"light", light.ToJson()},
          {"undistort", undistort.ToJson()},
          {"log_level", log_level}};
}

}  // namespace relit::calib
