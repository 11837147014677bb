// The steps of the capture stage, used by RunCaptureImpl (capture.cc):
// analysing a video (timestamps, quality scores, decode errors), audio sync,
// and writing the selected frames.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/audio_sync.h"
#include "capture/capture_options.h"
#include "capture/frame_select.h"
#include "capture/transfer.h"
#include "capture/video_io.h"

namespace relit::capture {

// One input video after the analysis pass.
struct AnalysedVideo {
  VideoInfo info;
  FileFingerprint fingerprint;
  Transfer transfer = Transfer::kSrgb;
  std::vector<Candidate> frames;  // every usable decoded frame, time_s = own clock
  DecodeIssue issue;              // kept only with allow_partial
  int frames_decoded = 0;         // before dropping frames after a decode error
  int output_width_px = 0, output_height_px = 0;
};

// Probes and fingerprints a video and picks its transfer function (cheap:
// done for every input before any decoding, so bad inputs fail early).
AnalysedVideo PrepareInput(const std::string& path, const std::string& role,
                           const CaptureOptions& options);

// Decodes and scores every frame. A decode error mid-stream is an error
// unless options.allow_partial, in which case the frames before it are
// kept. `label` names the progress bar.
void AnalyseFrames(AnalysedVideo* video, const CaptureOptions& options,
                   const SelectOptions& select, const std::string& label);

struct SyncResult {
  std::string method;          // "gcc-phat" or "manual"
  double offset_s = 0;         // t_view = t_light + offset_s
  double confidence = 0;       // gcc-phat only
  double peak = 0, second_peak = 0, second_peak_offset_s = 0;
  double view_audio_start_s = 0, light_audio_start_s = 0;
  double view_stream_start_s = 0, light_stream_start_s = 0;          // ffprobe start_time
  double view_first_packet_pts_s = 0, light_first_packet_pts_s = 0;  // < start: priming
  int view_audio_samples = 0, light_audio_samples = 0;
  DriftEstimate drift;         // gcc-phat only
  bool drift_corrected = false;
  // A phone L time on phone V's clock: the drift line when drift_corrected,
  // else t_light + offset_s.
  double ToViewTime(double light_time_s) const {
    return drift_corrected ? drift.ToView(light_time_s) : light_time_s + offset_s;
  }
  nlohmann::json ToJson(const SyncOptions& options) const;
};

// Manual offset, or GCC-PHAT on the two audio tracks (plus the drift
// estimate, applied with options.correct_drift). Throws relit::Error
// (naming the option to set) when a track is missing or the confidence is
// below options.min_confidence.
SyncResult Synchronise(const VideoInfo& view, const VideoInfo& light, const SyncOptions& options);

// Decodes `video` again and writes the frames `source_frames` (ascending) as
// <dir>/<NNNNNN>.<copy_format> (8-bit sRGB) and, with `linear_dir`, as
// <linear_dir>/<NNNNNN>.exr (linear half), N = position in the list.
void WriteFrames(const AnalysedVideo& video, const std::vector<int>& source_frames,
                 const CaptureOptions& options, const std::filesystem::path& root,
                 const std::string& dir, const std::string& linear_dir, const std::string& label);

// "view/000012.png"-style relative path.
std::string FramePath(const std::string& dir, int index, const std::string& extension);

// Per-input description for capture.json.
nlohmann::json InputJson(const AnalysedVideo& video);
// Scores of a candidate for capture.json.
nlohmann::json ScoreJson(const Candidate& candidate);

}  // namespace relit::capture
