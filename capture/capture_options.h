// Options of the capture stage (relit-capture): inputs, audio sync, frame
// selection, linearisation and output size. Defaults live here; the field
// tables (capture_options.cc) read the YAML file (unknown keys are errors),
// command-line flags go on top, then CheckOptions(). docs/capture.md's
// table is generated from the field tables (tools/options_doc).
#pragma once

#include <optional>
#include <string>

#include "core/option_fields.h"

namespace relit::capture {

struct SyncOptions {
  // Manual override: when set, t_view = t_light + offset_s and no audio is
  // needed. Unset means audio cross-correlation.
  std::optional<double> offset_s;
  int sample_rate_hz = 16000;        // both tracks are resampled to this rate
  double max_offset_s = 10.0;        // search window: |offset| <= max_offset_s
  double min_confidence = 2.0;       // main peak / best peak outside the exclusion zone
  double peak_exclusion_s = 0.005;   // half-width around the main peak ignored for the 2nd peak
  // Clock drift (audio sync only): the offset is measured in windows spread
  // over the overlap; above the warning rate the log warns, and with
  // correct_drift phone L times map to phone V's clock by the fitted line
  // t_view = a + (1 + b) * t_light instead of t_light + offset_s.
  bool correct_drift = false;
  double drift_window_s = 3.0;       // length of each window (shorter: less smear from the drift)
  double drift_warn_ms_per_min = 1.0;

  static const OptionFields<SyncOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

// Quality filters and subsampling, applied to phone V (and the geometry pass).
struct SelectOptions {
  int target_frames = 150;           // keep at most this many (0 = use target_fps)
  double target_fps = 0.0;           // alternatively: at most this many per second
  int blur_window_frames = 7;        // neighbours on each side for the relative blur score
  double min_blur_ratio = 0.6;       // sharpness / median sharpness of the neighbours
  double clip_level = 0.98;          // encoded luma at or above = clipped
  double max_clipped_fraction = 0.15;  // a flash-lit white board clips a little
  double dark_level = 0.02;          // encoded luma at or below = dark
  double max_dark_fraction = 0.995;  // dark rooms are expected: only near-black frames go
  double duplicate_max_diff = 0.0005;  // mean |luma difference| to the previous frame
  int analysis_width_px = 480;       // frames are scored at this width (or smaller)

  static const OptionFields<SelectOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

struct CaptureOptions {
  std::string view;                  // phone V video (no flash): the camera
  std::string light;                 // phone L video (flash on): the moving light
  std::string geometry;              // optional geometry-pass video or folder of photos
  std::string out;                   // output folder, WORKSPACE/capture

  SyncOptions sync;
  SelectOptions view_select;         // YAML "view"
  SelectOptions geometry_select;     // YAML "geometry_select"
  int light_frames_per_side = 2;     // phone L frames kept on each side of a kept V frame
  // Phone L frames closer in time than this to the previous candidate are
  // not candidates (0: every frame is). The light frames then follow the
  // phone V selection at most at this rate, not the video's frame rate.
  double light_min_spacing_s = 0;

  // "auto" (sRGB for SDR video, refuse HDR), "srgb", "gamma2.2", "hlg", "pq".
  std::string transfer = "auto";
  int max_long_side_px = 0;          // 0 = keep the video resolution
  std::string copy_format = "png";   // 8-bit copies: png | jpg
  int jpeg_quality = 95;
  bool allow_partial = false;        // keep the part of a damaged video before the first error
  std::string log_level = "info";
  // --force: replace an output folder that relit did not write (never one
  // holding an input, never a file). Not an option of the config file.
  bool force = false;

  static const OptionFields<CaptureOptions>& Fields();
  void Check() const;  // across fields and the file system; ranges: CheckOptions
};

}  // namespace relit::capture
