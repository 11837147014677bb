// Frame quality scores and frame selection: duplicates, badly exposed and
// blurred frames are rejected (each with its reason), the rest is subsampled
// evenly in time, and the phone L frames needed to interpolate the light at
// each kept phone V frame are found.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "capture/capture_options.h"

namespace relit::capture {

struct FrameScore {
  double sharpness = 0;          // variance of the Laplacian of luma in [0, 1]
  double clipped_fraction = 0;   // pixels with luma >= clip_level
  double dark_fraction = 0;      // pixels with luma <= dark_level
  double diff_to_previous = -1;  // mean |luma - previous luma|; -1 for the first frame
};

// Scores an 8-bit grey frame; `previous` may be empty.
FrameScore ScoreFrame(const cv::Mat& grey, const cv::Mat& previous, const SelectOptions& options);

// Rejection reasons, in the order they are tested.
inline constexpr const char* kDuplicate = "duplicate";
inline constexpr const char* kDark = "dark";
inline constexpr const char* kClipped = "clipped";
inline constexpr const char* kBlurred = "blurred";
inline constexpr const char* kNoLight = "outside_light_video";
inline constexpr const char* kNotSelected = "not_selected";

struct Candidate {
  int source_frame = 0;       // index in the decoded video (presentation order)
  double source_time_s = 0;   // own clock
  double time_s = 0;          // common clock
  FrameScore score;
  double blur_ratio = 1;      // sharpness / median sharpness of the neighbours
  std::string rejection;      // empty = kept so far
};

// Marks duplicates, dark/clipped frames and blurred frames (sharpness below
// min_blur_ratio x the median of the blur_window_frames neighbours on each
// side). Fills blur_ratio.
void RejectBadFrames(std::vector<Candidate>* candidates, const SelectOptions& options);

// Keeps at most the target number of the remaining frames: the time span is
// cut into equal bins and the sharpest frame of each bin is kept; the others
// are marked not_selected.
void Subsample(std::vector<Candidate>* candidates, const SelectOptions& options);

// Indices of the frames at times_s (ascending) kept when no two kept frames
// are closer than min_spacing_s: the first frame, then each frame at least
// min_spacing_s after the last kept one, and always the last frame (so the
// time range stays the same). min_spacing_s <= 0 keeps every frame.
std::vector<int> ThinByTime(const std::vector<double>& times_s, double min_spacing_s);

// Indices (into light_times_s, sorted ascending, common clock) of the phone L
// frames around time t: `per_side` at or before t and `per_side` at or after
// (fewer near the ends). Empty when t lies outside [first, last].
std::vector<int> LightFramesAround(double t_s, const std::vector<double>& light_times_s,
                                   int per_side);

}  // namespace relit::capture
