#include "capture/capture_options.h"

#include <cmath>
#include <filesystem>
#include <utility>

#include "core/error.h"

namespace relit::capture {

void SyncOptions::Read(OptionsReader& r) {
  if (r.Has("offset_s")) {
    r.Read("offset_s", &offset_s);
    manual = true;
  }
  r.ReadRange("sample_rate_hz", &sample_rate_hz, 1000, 96000);
  r.ReadRange("max_offset_s", &max_offset_s, 0.01, 600.0);
  r.ReadRange("min_confidence", &min_confidence, 1.0, 1000.0);
  r.ReadRange("peak_exclusion_s", &peak_exclusion_s, 0.0, 1.0);
  r.Read("correct_drift", &correct_drift);
  r.ReadRange("drift_window_s", &drift_window_s, 0.5, 600.0);
  r.ReadRange("drift_warn_ms_per_min", &drift_warn_ms_per_min, 0.0, 1000.0);
  r.Finish();
}

void SyncOptions::Check() const {
  RELIT_REQUIRE(std::isfinite(offset_s) && std::abs(offset_s) <= 3600,
                "sync.offset_s (--offset-s) must be a finite number of seconds below one hour, got ",
                offset_s);
  RELIT_REQUIRE(sample_rate_hz >= 1000 && sample_rate_hz <= 96000,
                "sync.sample_rate_hz must be in [1000, 96000], got ", sample_rate_hz);
  RELIT_REQUIRE(max_offset_s >= 0.01 && max_offset_s <= 600,
                "sync.max_offset_s (--max-offset-s) must be in [0.01, 600] s, got ", max_offset_s);
  RELIT_REQUIRE(min_confidence >= 1.0 && min_confidence <= 1000,
                "sync.min_confidence (--min-sync-confidence) must be in [1, 1000], got ",
                min_confidence);
  RELIT_REQUIRE(peak_exclusion_s >= 0 && peak_exclusion_s < max_offset_s,
                "sync.peak_exclusion_s must be in [0, sync.max_offset_s), got ", peak_exclusion_s);
  RELIT_REQUIRE(drift_window_s >= 0.5 && drift_window_s <= 600,
                "sync.drift_window_s must be in [0.5, 600] s, got ", drift_window_s);
  RELIT_REQUIRE(drift_warn_ms_per_min >= 0 && drift_warn_ms_per_min <= 1000,
                "sync.drift_warn_ms_per_min must be in [0, 1000], got ", drift_warn_ms_per_min);
}

nlohmann::json SyncOptions::ToJson() const {
  return {{"offset_s", manual ? nlohmann::json(offset_s) : nlohmann::json(nullptr)},
          {"sample_rate_hz", sample_rate_hz},
          {"max_offset_s", max_offset_s},
          {"min_confidence", min_confidence},
          {"peak_exclusion_s", peak_exclusion_s},
          {"correct_drift", correct_drift},
          {"drift_window_s", drift_window_s},
          {"drift_warn_ms_per_min", drift_warn_ms_per_min}};
}

void SelectOptions::Read(OptionsReader& r) {
  r.ReadRange("target_frames", &target_frames, 0, 1000000);
  r.ReadRange("target_fps", &target_fps, 0.0, 1000.0);
  r.ReadRange("blur_window_frames", &blur_window_frames, 1, 1000);
  r.ReadRange("min_blur_ratio", &min_blur_ratio, 0.0, 1.0);
  r.ReadRange("clip_level", &clip_level, 0.5, 1.0);
  r.ReadRange("max_clipped_fraction", &max_clipped_fraction, 0.0, 1.0);
  r.ReadRange("dark_level", &dark_level, 0.0, 0.5);
  r.ReadRange("max_dark_fraction", &max_dark_fraction, 0.0, 1.0);
  r.ReadRange("duplicate_max_diff", &duplicate_max_diff, 0.0, 0.5);
  r.ReadRange("analysis_width_px", &analysis_width_px, 32, 8192);
  r.Finish();
}

void SelectOptions::Check(const std::string& s) const {
  RELIT_REQUIRE(target_frames >= 0, s, ".target_frames (--target-frames) must be a positive number of phone V "
                "frames to keep, got ", target_frames, "; e.g. --target-frames 60");
  RELIT_REQUIRE(target_fps >= 0, s, ".target_fps must be a positive frame rate, got ", target_fps);
  RELIT_REQUIRE(target_frames >= 0 && target_fps >= 0 && (target_frames > 0) != (target_fps > 0),
                s, ": set exactly one of target_frames (--target-frames) and target_fps, got "
                "target_frames = ", target_frames, ", target_fps = ", target_fps);
  RELIT_REQUIRE(blur_window_frames >= 1, s, ".blur_window_frames must be >= 1, got ",
                blur_window_frames);
  RELIT_REQUIRE(min_blur_ratio >= 0 && min_blur_ratio <= 1, s,
                ".min_blur_ratio must be in [0, 1] (0 keeps blurred frames), got ", min_blur_ratio);
  RELIT_REQUIRE(clip_level > dark_level && clip_level <= 1 && dark_level >= 0, s,
                ": need 0 <= dark_level < clip_level <= 1, got dark_level = ", dark_level,
                ", clip_level = ", clip_level);
  RELIT_REQUIRE(max_clipped_fraction >= 0 && max_clipped_fraction <= 1 &&
                    max_dark_fraction >= 0 && max_dark_fraction <= 1,
                s, ": max_clipped_fraction and max_dark_fraction must be in [0, 1]");
  RELIT_REQUIRE(duplicate_max_diff >= 0 && duplicate_max_diff < 0.5, s,
                ".duplicate_max_diff must be in [0, 0.5), got ", duplicate_max_diff);
  RELIT_REQUIRE(analysis_width_px >= 32, s, ".analysis_width_px must be >= 32, got ",
                analysis_width_px);
}

nlohmann::json SelectOptions::ToJson() const {
  return {{"target_frames", target_frames},
          {"target_fps", target_fps},
          {"blur_window_frames", blur_window_frames},
          {"min_blur_ratio", min_blur_ratio},
          {"clip_level", clip_level},
          {"max_clipped_fraction", max_clipped_fraction},
          {"dark_level", dark_level},
          {"max_dark_fraction", max_dark_fraction},
          {"duplicate_max_diff", duplicate_max_diff},
          {"analysis_width_px", analysis_width_px}};
}

void CaptureOptions::Read(OptionsReader& r) {
  r.Read("view", &view);
  r.Read("light", &light);
  r.Read("geometry", &geometry);
  r.Read("out", &out);
  OptionsReader sync_reader = r.Child("sync");
  sync.Read(sync_reader);
  OptionsReader view_reader = r.Child("view_select");
  view_select.Read(view_reader);
  OptionsReader geometry_reader = r.Child("geometry_select");
  geometry_select.Read(geometry_reader);
  r.ReadRange("light_frames_per_side", &light_frames_per_side, 1, 100);
  r.Read("transfer", &transfer);
  r.ReadRange("max_long_side_px", &max_long_side_px, 0, 100000);
  r.Read("copy_format", &copy_format);
  r.ReadRange("jpeg_quality", &jpeg_quality, 1, 100);
  r.Read("allow_partial", &allow_partial);
  r.Read("log_level", &log_level);
  r.Finish();
}

void CaptureOptions::Check() const {
  RELIT_REQUIRE(!view.empty(), "no phone V video: pass --view VIDEO (the phone filming without flash)");
  RELIT_REQUIRE(!light.empty(), "no phone L video: pass --light VIDEO (the phone with its flash on)");
  RELIT_REQUIRE(!out.empty(), "no output folder: pass --out WORKSPACE/capture");
  {
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
  }
  sync.Check();
  view_select.Check("view_select");
  geometry_select.Check("geometry_select");
  RELIT_REQUIRE(light_frames_per_side >= 1 && light_frames_per_side <= 100,
                "light_frames_per_side must be in [1, 100], got ", light_frames_per_side);
  RELIT_REQUIRE(transfer == "auto" || transfer == "srgb" || transfer == "gamma2.2" ||
                    transfer == "hlg" || transfer == "pq",
                "transfer (--transfer) must be auto, srgb, gamma2.2, hlg or pq, got '", transfer,
                "'");
  RELIT_REQUIRE(max_long_side_px == 0 || (max_long_side_px >= 64 && max_long_side_px <= 100000),
                "max_long_side_px (--max-long-side-px) must be 0 (keep the video size) or >= 64, "
                "got ", max_long_side_px);
  RELIT_REQUIRE(copy_format == "png" || copy_format == "jpg",
                "copy_format must be png or jpg, got '", copy_format, "'");
  RELIT_REQUIRE(jpeg_quality >= 1 && jpeg_quality <= 100, "jpeg_quality must be in [1, 100], got ",
                jpeg_quality);
}

nlohmann::json CaptureOptions::ToJson() const {
  return {{"view", view},
          {"light", light},
          {"geometry", geometry},
          {"out", out},
          {"sync", sync.ToJson()},
          {"view_select", view_select.ToJson()},
          {"geometry_select", geometry_select.ToJson()},
          {"light_frames_per_side", light_frames_per_side},
          {"transfer", transfer},
          {"max_long_side_px", max_long_side_px},
          {"copy_format", copy_format},
          {"jpeg_quality", jpeg_quality},
          {"allow_partial", allow_partial},
          {"log_level", log_level}};
}

}  // namespace relit::capture
