// The steps of relit-calib between reading capture.json and writing the
// outputs: board detection on all frames, the first lens estimates, the
// COLMAP model aligned to the board and added to the bundle problem, and the
// board scale check. Each step returns its part of calib_report.json.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/board_detect.h"
#include "calib/board_pose.h"
#include "calib/bundle.h"
#include "calib/calib_options.h"
#include "calib/capture_file.h"

namespace relit::calib {

struct CalibFrame {
  CaptureFrame capture;
  BoardObservation board;
};

// The lens a device is calibrated with: the geometry pass is filmed with
// phone V, so it shares phone V's lens in the bundle problem.
inline std::string LensOf(const std::string& device) { return device == "geometry" ? "view" : device; }

// The "geometry" report section: geometry-pass frames detected, posed by the
// board, registered by COLMAP, registered in the end, and their board-corner
// RMS after the final refinement. `frames[i]` is `problem.frames[i]`.
nlohmann::json GeometryPassReport(const std::vector<CalibFrame>& frames, const BundleProblem& problem,
                                  const std::vector<bool>& posed_by_board, const BundleStats& stats,
                                  const nlohmann::json& sfm_report, int min_corners);

// Detects the board in every frame (in parallel, with a progress bar).
// `workspace` is the root the frame paths are relative to.
std::vector<CalibFrame> DetectAll(const std::string& workspace, const std::vector<CaptureFrame>& frames,
                                  const BoardDetector& detector, int threads, const std::string& label);

// Throws the "board never detected" error when no frame shows at least
// `min_corners` ChArUco corners, with the markers found and the dictionary.
void RequireBoardSeen(const std::vector<CalibFrame>& frames, const BoardSpec& spec,
                      const BoardDetector& detector, int min_corners);

// Detection statistics of one device (counts, ms per frame of each detector).
nlohmann::json DetectionReport(const std::vector<CalibFrame>& frames, const std::string& device,
                               int min_corners);

// First lens of `device`: from its board_images folder when set (the lens
// then stays fixed: *fixed = true), otherwise from the capture frames.
BoardCalibration InitialLens(const std::vector<CalibFrame>& frames, const std::string& device, int width,
                             int height, const CalibOptions& options, const BoardDetector& detector,
                             bool* fixed, nlohmann::json* report);

// sfm.mode as run: "auto" becomes board_seeded from auto_seeded_min_images
// images on when at least two frames can seed the model, else incremental;
// `why` says which and why (for the log and the report).
std::string ResolveSfmMode(const SfmOptions& so, size_t images, size_t seed_frames, std::string* why);

// Runs COLMAP on the frames, aligns its largest model to the board poses in
// `problem` (robust similarity on camera centres), gives frames without a
// board pose their SfM pose and adds the SfM points. `frames[i]` is
// `problem->frames[i]`. Returns the "sfm" report section.
nlohmann::json AddStructureFromMotion(const std::vector<CalibFrame>& frames, const std::string& workspace,
                                      const std::string& work_dir, const CalibOptions& options,
                                      BundleProblem* problem, std::map<std::string, double>* timings_s);

// Measures the marker-to-square side ratio over all posed frames and throws
// when it differs from the configured board by more than
// refine.max_ratio_error. Returns the "scale_check" report section.
nlohmann::json CheckBoardScale(const std::vector<CalibFrame>& frames, const BundleProblem& problem,
                               const CalibOptions& options, double* measured_ratio);

// Why a frame ended up without a pose, in one line for calib_report.json
// and calib.log: what the board detection found (markers of board_markers,
// corners against min_corners), whether its board pose was dropped, and
// what COLMAP said when SfM ran.
std::string UnregisteredReason(const CalibFrame& frame, bool posed_by_board, const nlohmann::json& sfm_report,
                               int min_corners, int board_markers);

}  // namespace relit::calib
