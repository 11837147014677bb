#include "capture/capture_options.h"

#include <filesystem>
#include <utility>

#include "core/error.h"
#include "core/log.h"

namespace relit::capture {

RELIT_OPTION_FIELDS(SyncOptions,
    .Add("offset_s", &S::offset_s, -3600, 3600,
         "manual offset t_view - t_light, s (`--offset-s`); set, it replaces audio sync")
    .Add("sample_rate_hz", &S::sample_rate_hz, 1000, 96000, "both audio tracks are resampled to this rate")
    .Add("max_offset_s", &S::max_offset_s, 0.01, 600.0, "search window: |offset| up to this (`--max-offset-s`)")
    .Add("min_confidence", &S::min_confidence, 1.0, 1000.0,
         "smallest accepted ratio main peak / best peak outside the exclusion (`--min-sync-confidence`)")
    .Add("peak_exclusion_s", &S::peak_exclusion_s, 0.0, 1.0,
         "half-width around the main peak ignored when finding the second peak; below max_offset_s")
    .Add("correct_drift", &S::correct_drift,
         "map phone L times through the fitted clock drift line (`--correct-drift`)")
    .Add("drift_window_s", &S::drift_window_s, 0.5, 600.0, "length of each drift window, s")
    .Add("drift_warn_ms_per_min", &S::drift_warn_ms_per_min, 0.0, 1000.0, "warn when |drift| is above this"))

void SyncOptions::Check() const {
  RELIT_REQUIRE(peak_exclusion_s < max_offset_s, "peak_exclusion_s must be below max_offset_s (",
                max_offset_s, "), got ", peak_exclusion_s);
}

RELIT_OPTION_FIELDS(SelectOptions,
    .Add("target_frames", &S::target_frames, 0, 1000000,
         "keep at most this many frames (0: use target_fps; `--target-frames` sets view_select's)")
    .Add("target_fps", &S::target_fps, 0.0, 1000.0, "alternatively, at most this many frames per second")
    .Add("blur_window_frames", &S::blur_window_frames, 1, 1000, "neighbours on each side for the blur median")
    .Add("min_blur_ratio", &S::min_blur_ratio, 0.0, 1.0,
         "reject when sharpness < ratio x median of the neighbours (0 keeps all)")
    .Add("clip_level", &S::clip_level, 0.5, 1.0, "encoded luma at or above this is clipped")
    .Add("max_clipped_fraction", &S::max_clipped_fraction, 0.0, 1.0, "reject when more pixels are clipped")
    .Add("dark_level", &S::dark_level, 0.0, 0.5, "encoded luma at or below this is dark; below clip_level")
    .Add("max_dark_fraction", &S::max_dark_fraction, 0.0, 1.0,
         "reject when more pixels are dark (a dark room is expected)")
    .Add("duplicate_max_diff", &S::duplicate_max_diff, 0.0, 0.5,
         "mean luma difference to the previous frame below this: a duplicate")
    .Add("analysis_width_px", &S::analysis_width_px, 32, 8192, "frames are scored at this width"))

void SelectOptions::Check() const {
  RELIT_REQUIRE((target_frames > 0) != (target_fps > 0),
                "set exactly one of target_frames (--target-frames) and target_fps, got target_frames = ",
                target_frames, ", target_fps = ", target_fps);
  RELIT_REQUIRE(dark_level < clip_level, "need dark_level < clip_level, got dark_level = ", dark_level,
                ", clip_level = ", clip_level);
}

RELIT_OPTION_FIELDS(CaptureOptions,
    .Add("view", &S::view, "phone V video, filmed without flash (`--view`; pipeline: inputs.view)")
    .Add("light", &S::light, "phone L video, filmed with its flash on (`--light`; pipeline: inputs.light)")
    .Add("geometry", &S::geometry, "optional geometry-pass video or folder of photos (`--geometry`)")
    .Add("out", &S::out, "output folder, W/capture (`--out`; pipeline: the workspace)")
    .Section("sync", &S::sync)
    .Section("view_select", &S::view_select)
    .Section("geometry_select", &S::geometry_select)
    .Add("light_frames_per_side", &S::light_frames_per_side, 1, 100,
         "phone L frames kept on each side of a kept phone V frame")
    .Add("light_min_spacing_s", &S::light_min_spacing_s, 0.0, 1.0,
         "phone L frames are candidates at most this often (s; 0: every frame): 0.06 keeps every "
         "other frame of a 30 fps phone L; below 2 x calib's light.max_gap_s (0.1 s), else calib "
         "marks the lights unreliable")
    .Add("transfer", &S::transfer, {"auto", "srgb", "gamma2.2", "hlg", "pq"},
         "transfer function of the videos (`--transfer`; auto: sRGB, refuse HDR)")
    .Add("max_long_side_px", &S::max_long_side_px, 0, 100000,
         "downscale (in linear light) to this long side, 0 or >= 64 (`--max-long-side-px`; 0 keeps the size)")
    .Add("copy_format", &S::copy_format, {"png", "jpg"}, "format of the 8-bit copies")
    .Add("jpeg_quality", &S::jpeg_quality, 1, 100, "quality of jpg copies")
    .Add("allow_partial", &S::allow_partial,
         "keep the frames of a damaged video before its first decode error (`--allow-partial`)")
    .Add("log_level", &S::log_level, LogLevelNames(), "what the stage prints (`--log-level`)"))

void CaptureOptions::Check() const {
  RELIT_REQUIRE(!view.empty(), "no phone V video: pass --view VIDEO (the phone filming without flash)");
  RELIT_REQUIRE(!light.empty(), "no phone L video: pass --light VIDEO (the phone with its flash on)");
  RELIT_REQUIRE(!out.empty(), "no output folder: pass --out WORKSPACE/capture");
  std::error_code ec;
  const auto same = std::filesystem::equivalent(view, light, ec);
  RELIT_REQUIRE(!(same && !ec) && view != light, "the phone V video (--view, inputs.view) and the phone L "
                "video (--light, inputs.light) are the same file, ", view,
                ": give the two phones' own videos");
  for (const auto& [path, role] : {std::pair<std::string, const char*>{view, "phone V video (--view, inputs.view)"},
                                   {light, "phone L video (--light, inputs.light)"}}) {
    RELIT_REQUIRE(!std::filesystem::is_directory(path, ec), "the ", role, " ", path,
                  " is a folder: give the video file");
  }
  RELIT_REQUIRE(max_long_side_px == 0 || max_long_side_px >= 64,
                "max_long_side_px (--max-long-side-px) must be 0 (keep the video size) or >= 64, got ",
                max_long_side_px);
}

}  // namespace relit::capture
