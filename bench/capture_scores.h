// One row of figures for a pipeline run on a capture with ground truth
// (relit-synth's or the Cycles capture's truth.json): what each stage got
// right, read from the workspace's files only.
//
//   capture:     sync error: phone L frames' times minus phone V frames' times in
//                capture.json, each against truth.json's t_common_s (capture.json
//                uses the files' presentation times, truth.json counts from frame 0)
//   calib:       camera ATE (RMSE of camera centres after a similarity
//                alignment, Umeyama) per phone, and calib/truth_accuracy.cc's
//                medians in the board frame (no alignment), flash position
//   reconstruct: proxy symmetric mean Chamfer distance to the truth objects
//   relight:     eval.json's PSNR per method over all eval images, and the
//                truth's own noise floor (its noise halves or twins)
//
// A figure whose input is missing is an error, not a blank: a scorer that
// silently finds no truth hides a defect.
#pragma once

#include <map>
#include <string>

#include <nlohmann/json.hpp>

namespace relit::bench {

struct CaptureScores {
  double sync_offset_s = 0, truth_offset_s = 0, sync_error_ms = 0;
  std::map<std::string, int> ate_frames;          // "view", "light"
  std::map<std::string, double> ate_mm;           // RMSE after similarity alignment
  std::map<std::string, double> ate_scale;        // the alignment's scale
  nlohmann::json calib_accuracy;                  // calib::CalibAccuracy::ToJson()
  double chamfer_mm = 0, chamfer_percent = 0;     // of the truth objects' bounding-box diagonal
  std::map<std::string, double> psnr_db;          // eval method -> PSNR over all images
  double noise_floor_db = 0;                      // the truth's noise floor, all images
  int eval_images = 0;
  nlohmann::json ToJson() const;
};

// `workspace` is the pipeline's workspace, `capture_dir` the folder with
// truth.json the capture was made from.
CaptureScores ScoreCapture(const std::string& workspace, const std::string& capture_dir);

// Markdown table of rows side by side (first column the figure names), with
// the ratio of the second row to the first where both are positive.
std::string ScoresTable(const std::vector<std::pair<std::string, CaptureScores>>& rows);

}  // namespace relit::bench
