#include "capture/capture_steps.h"

#include <set>

#include <algorithm>
#include <cmath>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "capture/audio_sync.h"
#include "core/error.h"
#include "core/image.h"
#include "core/progress.h"

namespace relit::capture {

namespace {

namespace fs = std::filesystem;

void OutputSize(const VideoInfo& info, int max_long_side_px, int* width, int* height) {
  const int long_side = std::max(info.width_px, info.height_px);
  if (max_long_side_px <= 0 || long_side <= max_long_side_px) {
    *width = info.width_px;
    *height = info.height_px;
    return;
  }
  const double scale = static_cast<double>(max_long_side_px) / long_side;
  *width = std::max(1, static_cast<int>(std::lround(info.width_px * scale)));
  *height = std::max(1, static_cast<int>(std::lround(info.height_px * scale)));
}

}  // namespace

std::string FramePath(const std::string& dir, int index, const std::string& extension) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.", index);
  return dir + "/" + name + extension;
}

AnalysedVideo PrepareInput(const std::string& path, const std::string& role,
                           const CaptureOptions& options) {
  AnalysedVideo video;
  video.info = ProbeVideo(path, role);
  // ffmpeg opens a still image as a one-frame "video"; with --offset-s it
  // would become a one-frame capture.
  static const std::set<std::string> kImageCodecs = {"png", "bmp", "tiff", "webp", "gif", "pam", "pgm",
                                                     "ppm", "pbm", "jpeg2000", "jpegls", "exr", "hdr"};
  RELIT_REQUIRE(kImageCodecs.count(video.info.codec) == 0 &&
                    !(video.info.codec == "mjpeg" && video.info.header_frame_count <= 1),
                "the ", role, " ", path, " is a still image (", video.info.codec,
                "), not a video: give the phone's video file (MP4/MOV)");
  video.transfer = ResolveTransfer(video.info, options.transfer);
  video.fingerprint = Fingerprint(path);
  OutputSize(video.info, options.max_long_side_px, &video.output_width_px, &video.output_height_px);
  spdlog::info("{}: {} {} {}x{} {}-bit, rotation {} deg, transfer tag '{}' -> {}, {:.2f} s{}",
               role, path, video.info.codec, video.info.coded_width_px, video.info.coded_height_px,
               video.info.bit_depth, video.info.rotation_deg, video.info.color_transfer,
               ToString(video.transfer), video.info.duration_s,
               video.info.has_audio ? ", with audio" : ", no audio");
  return video;
}

void AnalyseFrames(AnalysedVideo* video_ptr, const CaptureOptions& options,
                   const SelectOptions& select, const std::string& label) {
  AnalysedVideo& video = *video_ptr;
  const std::string& path = video.info.path;
  const std::string& role = video.info.role;
  Progress progress(label, video.info.header_frame_count);
  std::vector<FrameScore> scores;
  cv::Mat previous;
  const AnalysisPass pass =
      AnalyseVideo(video.info, select.analysis_width_px, [&](int, const cv::Mat& grey) {
        scores.push_back(ScoreFrame(grey, previous, select));
        grey.copyTo(previous);
        progress.Advance();
      });
  progress.Finish();
  video.frames_decoded = static_cast<int>(pass.times_s.size());
  int usable = video.frames_decoded;
  if (pass.issue.found) {
    RELIT_REQUIRE(options.allow_partial, "the ", role, " ", path, " has a decode error at t = ",
                  pass.issue.time_s, " s (after ", pass.issue.frames_before, " of ",
                  video.frames_decoded, " frames): ", pass.issue.message,
                  "; the file is damaged or truncated: copy it from the phone again, or pass "
                  "--allow-partial to keep the ", pass.issue.frames_before,
                  " frames before the error");
    RELIT_REQUIRE(pass.issue.frames_before > 0, "the ", role, " ", path,
                  " has a decode error before its first frame (", pass.issue.message,
                  "): nothing usable; copy the file from the phone again");
    usable = pass.issue.frames_before;
    video.issue = pass.issue;
    spdlog::warn("{}: decode error at t = {:.3f} s ({}); keeping the {} frames before it "
                 "(--allow-partial)", path, pass.issue.time_s, pass.issue.message, usable);
  }
  RELIT_REQUIRE(usable > 0, "the ", role, " ", path, " has no decodable video frames");
  RELIT_REQUIRE(usable > 1, "the ", role, " ", path,
                " has a single frame (a still image?): give the phone's video file (MP4/MOV)");
  for (int i = 0; i < usable; ++i) {
    Candidate c;
    c.source_frame = i;
    c.source_time_s = pass.times_s[i];
    c.time_s = pass.times_s[i];
    c.score = scores[i];
    video.frames.push_back(c);
  }
}

namespace {

nlohmann::json DriftJson(const DriftEstimate& d, bool corrected, const SyncOptions& o) {
  nlohmann::json j = {{"model", "t_view = intercept_s + (1 + rate) * t_light"},
                      {"valid", d.valid},
                      {"corrected", corrected},
                      {"warn_ms_per_min", o.drift_warn_ms_per_min},
                      {"window_s", d.window_s}};
  if (!d.valid) {
    j["reason"] = d.reason;
    j["drift_ms_per_min"] = nullptr;
    return j;
  }
  j["drift_ms_per_min"] = d.ms_per_min();
  j["rate"] = d.rate;
  j["intercept_s"] = d.intercept_s;
  j["overlap_start_light_s"] = d.overlap_start_s;
  j["overlap_end_light_s"] = d.overlap_end_s;
  j["offset_at_start_s"] = d.offset_at_start_s;
  j["offset_at_end_s"] = d.offset_at_end_s;
  nlohmann::json windows = nlohmann::json::array();
  for (const DriftWindow& w : d.windows) {
    windows.push_back({{"light_time_s", w.light_time_s}, {"offset_s", w.offset_s},
                       {"confidence", w.confidence}});
  }
  j["windows"] = windows;
  return j;
}

}  // namespace

nlohmann::json SyncResult::ToJson(const SyncOptions& o) const {
  nlohmann::json j = {{"method", method},
                      {"offset_s", offset_s},
                      {"definition", "t_view = t_light + offset_s (phone V's clock is the common "
                                     "clock; offset_s > 0: phone L started recording later)"}};
  if (method == "gcc-phat") {
    j["confidence"] = confidence;
    j["min_confidence"] = o.min_confidence;
    j["peak"] = peak;
    j["second_peak"] = second_peak;
    j["second_peak_offset_s"] = second_peak_offset_s;
    j["sample_rate_hz"] = o.sample_rate_hz;
    j["search_window_s"] = o.max_offset_s;
    j["view_audio_start_s"] = view_audio_start_s;
    j["light_audio_start_s"] = light_audio_start_s;
    j["view_audio_samples"] = view_audio_samples;
    j["light_audio_samples"] = light_audio_samples;
    j["view_stream_start_s"] = view_stream_start_s;
    j["light_stream_start_s"] = light_stream_start_s;
    j["view_first_packet_pts_s"] = view_first_packet_pts_s;
    j["light_first_packet_pts_s"] = light_first_packet_pts_s;
    j["drift"] = DriftJson(drift, drift_corrected, o);
  } else {
    j["confidence"] = nullptr;
  }
  return j;
}

namespace {

void EstimateSyncDrift(const AudioTrack& a, const AudioTrack& b, const SyncOptions& o,
                       SyncResult* result) {
  result->drift = EstimateDrift({&a.samples, a.start_s, a.sample_rate_hz},
                                {&b.samples, b.start_s, b.sample_rate_hz}, result->offset_s,
                                o.drift_window_s, 0.1, o.min_confidence);
  const DriftEstimate& d = result->drift;
  if (!d.valid) {
    spdlog::log(o.correct_drift ? spdlog::level::warn : spdlog::level::info,
                "sync: no clock drift estimate: {}{}", d.reason,
                o.correct_drift ? "; sync.correct_drift not applied" : "");
    return;
  }
  result->drift_corrected = o.correct_drift;
  spdlog::log(std::abs(d.ms_per_min()) > o.drift_warn_ms_per_min ? spdlog::level::warn
                                                                 : spdlog::level::info,
              "sync: clock drift {:+.3f} ms/min (offset {:+.6f} s at the start of the overlap, "
              "{:+.6f} s at its end, {} windows){}", d.ms_per_min(), d.offset_at_start_s,
              d.offset_at_end_s, d.windows.size(),
              o.correct_drift ? "; corrected (sync.correct_drift)"
              : std::abs(d.ms_per_min()) > o.drift_warn_ms_per_min
                  ? "; above sync.drift_warn_ms_per_min: set sync.correct_drift: true"
                  : "");
}

}  // namespace

SyncResult Synchronise(const VideoInfo& view, const VideoInfo& light, const SyncOptions& o) {
  SyncResult result;
  if (o.offset_s) {
    result.method = "manual";
    result.offset_s = *o.offset_s;
    spdlog::info("sync: manual offset {:+.6f} s (t_view = t_light + offset)", *o.offset_s);
    if (o.correct_drift) {
      spdlog::warn("sync: sync.correct_drift needs audio sync; not applied with a manual offset");
    }
    return result;
  }
  for (const VideoInfo* info : {&view, &light}) {
    RELIT_REQUIRE(info->has_audio, "the ", info->role, " ", info->path,
                  " has no audio track, so the two videos cannot be synchronised by sound: pass "
                  "--offset-s SECONDS (when phone L started, on phone V's clock; see "
                  "docs/capture.md) or film with sound recording on");
  }
  const AudioTrack a = DecodeAudio(view, o.sample_rate_hz);
  const AudioTrack b = DecodeAudio(light, o.sample_rate_hz);
  const LagEstimate lag = GccPhatLag(a.samples, b.samples, o.sample_rate_hz, o.max_offset_s,
                                     o.peak_exclusion_s);
  result.method = "gcc-phat";
  // Sample n of `a` is at a.start_s + n / rate (phone V clock); the same sound
  // is sample n - lag of `b`, at b.start_s + (n - lag) / rate on phone L's clock.
  result.offset_s = (a.start_s - b.start_s) + lag.lag_s;
  result.confidence = lag.confidence;
  result.peak = lag.peak;
  result.second_peak = lag.second_peak;
  result.second_peak_offset_s = (a.start_s - b.start_s) + lag.second_lag_s;
  result.view_audio_start_s = a.start_s;
  result.light_audio_start_s = b.start_s;
  result.view_stream_start_s = a.stream_start_s;
  result.light_stream_start_s = b.stream_start_s;
  result.view_first_packet_pts_s = a.first_packet_pts_s;
  result.light_first_packet_pts_s = b.first_packet_pts_s;
  result.view_audio_samples = static_cast<int>(a.samples.size());
  result.light_audio_samples = static_cast<int>(b.samples.size());
  spdlog::info("sync: GCC-PHAT offset {:+.6f} s, confidence {:.2f} (second peak at {:+.4f} s; "
               "audio starts at {:.6f} s (V) and {:.6f} s (L))", result.offset_s,
               result.confidence, result.second_peak_offset_s, a.start_s, b.start_s);
  RELIT_REQUIRE(result.confidence >= o.min_confidence,
                "audio sync of ", view.path, " and ", light.path, " failed: confidence ",
                result.confidence, " is below sync.min_confidence = ", o.min_confidence,
                " (best offset ", result.offset_s, " s; the sound tracks do not match clearly: "
                "unrelated recordings, silence, or an offset beyond sync.max_offset_s = ",
                o.max_offset_s, " s). Clap once near both phones at the start and film again, or "
                "pass --offset-s SECONDS (or --max-offset-s / --min-sync-confidence)");
  EstimateSyncDrift(a, b, o, &result);
  return result;
}

void WriteFrames(const AnalysedVideo& video, const std::vector<int>& source_frames,
                 const CaptureOptions& options, const fs::path& root, const std::string& dir,
                 const std::string& linear_dir, const std::string& label) {
  if (source_frames.empty()) return;
  RELIT_CHECK(std::is_sorted(source_frames.begin(), source_frames.end()));
  fs::create_directories(root / dir);
  if (!linear_dir.empty()) fs::create_directories(root / linear_dir);
  const Linearizer linearizer(video.transfer, (video.transfer == Transfer::kHlg ||
                                               video.transfer == Transfer::kPq) &&
                                                  video.info.color_primaries == "bt2020");
  const cv::Size size(video.output_width_px, video.output_height_px);
  std::vector<int> params;
  if (options.copy_format == "jpg") params = {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality};
  Progress progress(label, static_cast<int64_t>(source_frames.size()));
  FrameReader reader(video.info);
  cv::Mat rgb16, bgr8;
  size_t next = 0;
  while (next < source_frames.size() && reader.Next(&rgb16)) {
    if (reader.index() != source_frames[next]) continue;
    cv::Mat linear = linearizer.ToLinear(rgb16);
    // Downscaling averages light, so it happens on linear values.
    if (linear.size() != size) cv::resize(linear, linear, size, 0, 0, cv::INTER_AREA);
    if (!linear_dir.empty()) {
      WriteImage((root / FramePath(linear_dir, static_cast<int>(next), "exr")).string(), Image::FromMat(linear));
    }
    cv::cvtColor(LinearToSrgb8(linear), bgr8, cv::COLOR_RGB2BGR);
    const std::string path = (root / FramePath(dir, static_cast<int>(next), options.copy_format)).string();
    RELIT_REQUIRE(cv::imwrite(path, bgr8, params), "cannot write ", path);
    ++next;
    progress.Advance();
  }
  reader.Close();
  progress.Finish();
  RELIT_REQUIRE(next == source_frames.size(), "decoding the ", video.info.role, " ",
                video.info.path, " again gave only ", reader.index() + 1,
                " frames; the file changed during the run?");
}

nlohmann::json InputJson(const AnalysedVideo& v) {
  const VideoInfo& i = v.info;
  nlohmann::json j = {
      {"path", fs::absolute(i.path).lexically_normal().string()},
      {"size_bytes", v.fingerprint.size_bytes},
      {"fnv1a64", v.fingerprint.fnv1a64},
      {"container", i.container},
      {"codec", i.codec},
      {"pix_fmt", i.pix_fmt},
      {"bit_depth", i.bit_depth},
      {"coded_width_px", i.coded_width_px},
      {"coded_height_px", i.coded_height_px},
      {"rotation_deg", i.rotation_deg},
      {"width_px", i.width_px},
      {"height_px", i.height_px},
      {"output_width_px", v.output_width_px},
      {"output_height_px", v.output_height_px},
      {"color_transfer", i.color_transfer},
      {"color_space", i.color_space},
      {"color_range", i.color_range},
      {"color_primaries", i.color_primaries},
      {"transfer_used", ToString(v.transfer)},
      {"duration_s", i.duration_s},
      {"frames_decoded", v.frames_decoded},
      {"frames_usable", static_cast<int>(v.frames.size())},
      {"first_frame_time_s", v.frames.front().source_time_s},
      {"last_frame_time_s", v.frames.back().source_time_s},
      {"has_audio", i.has_audio},
      {"audio_sample_rate_hz", i.audio_sample_rate_hz}};
  j["decode_error"] = v.issue.found ? nlohmann::json{{"time_s", v.issue.time_s},
                                                     {"frames_before", v.issue.frames_before},
                                                     {"message", v.issue.message}}
                                    : nlohmann::json(nullptr);
  return j;
}

nlohmann::json ScoreJson(const Candidate& c) {
  return {{"source_frame", c.source_frame},
          {"source_time_s", c.source_time_s},
          {"time_s", c.time_s},
          {"sharpness", c.score.sharpness},
          {"blur_ratio", c.blur_ratio},
          {"clipped_fraction", c.score.clipped_fraction},
          {"dark_fraction", c.score.dark_fraction}};
}

}  // namespace relit::capture
