#include "capture/capture.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <utility>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "capture/capture_steps.h"
#include "core/atomic_output.h"
#include "core/color.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/stage_run.h"

namespace relit::capture {

namespace {

namespace fs = std::filesystem;

constexpr const char* kViewRole = "phone V video (--view)";
constexpr const char* kLightRole = "phone L video (--light)";
constexpr const char* kGeometryRole = "geometry-pass video (--geometry)";

std::string RejectionSummary(const std::vector<Candidate>& frames) {
  std::map<std::string, int> counts;
  for (const Candidate& c : frames) counts[c.rejection.empty() ? "kept" : c.rejection]++;
  std::string text;
  for (const auto& [reason, count] : counts) {
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + reason;
  }
  return text;
}

nlohmann::json Counts(const std::vector<Candidate>& frames) {
  nlohmann::json counts = nlohmann::json::object();
  for (const Candidate& c : frames) {
    const std::string key = c.rejection.empty() ? "kept" : c.rejection;
    counts[key] = counts.value(key, 0) + 1;
  }
  return counts;
}

nlohmann::json RejectedJson(const std::vector<Candidate>& frames) {
  nlohmann::json rejected = nlohmann::json::array();
  for (const Candidate& c : frames) {
    if (c.rejection.empty()) continue;
    nlohmann::json j = ScoreJson(c);
    j["reason"] = c.rejection;
    rejected.push_back(j);
  }
  return rejected;
}

bool IsPhoto(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff" ||
         ext == ".bmp" || ext == ".webp";
}

// A folder of photos for the geometry pass: every photo is kept (in file name
// order), scored and converted to an 8-bit sRGB copy.
nlohmann::json CapturePhotos(const CaptureOptions& o, const fs::path& root, nlohmann::json* frames) {
  std::vector<fs::path> photos;
  for (const auto& entry : fs::directory_iterator(o.geometry)) {
    if (entry.is_regular_file() && IsPhoto(entry.path())) photos.push_back(entry.path());
  }
  std::sort(photos.begin(), photos.end());
  RELIT_REQUIRE(!photos.empty(), "the geometry folder (--geometry) ", o.geometry,
                " holds no photos (.jpg, .png, .tif, .bmp, .webp)");
  fs::create_directories(root / "geometry");
  Progress progress("geometry photos", static_cast<int64_t>(photos.size()));
  for (size_t i = 0; i < photos.size(); ++i) {
    // IMREAD_COLOR applies the EXIF orientation, like the rotation of videos.
    const cv::Mat bgr = cv::imread(photos[i].string(), cv::IMREAD_COLOR);
    RELIT_REQUIRE(!bgr.empty(), "cannot read the geometry photo ", photos[i].string(),
                  ": not an image or damaged; remove it from the folder");
    cv::Mat out = bgr, grey;
    const int long_side = std::max(bgr.cols, bgr.rows);
    if (o.max_long_side_px > 0 && long_side > o.max_long_side_px) {
      const double scale = static_cast<double>(o.max_long_side_px) / long_side;
      cv::Mat linear(bgr.size(), CV_32FC3);
      bgr.convertTo(linear, CV_32FC3, 1.0 / 255.0);
      for (auto it = linear.begin<cv::Vec3f>(); it != linear.end<cv::Vec3f>(); ++it) {
        for (int c = 0; c < 3; ++c) (*it)[c] = SrgbToLinear((*it)[c]);
      }
      cv::resize(linear, linear, cv::Size(), scale, scale, cv::INTER_AREA);
      for (auto it = linear.begin<cv::Vec3f>(); it != linear.end<cv::Vec3f>(); ++it) {
        for (int c = 0; c < 3; ++c) (*it)[c] = LinearToSrgb(std::clamp((*it)[c], 0.0f, 1.0f));
      }
      linear.convertTo(out, CV_8UC3, 255.0);
    }
    cv::cvtColor(out, grey, cv::COLOR_BGR2GRAY);
    const int analysis_width = std::min(o.geometry_select.analysis_width_px, grey.cols);
    cv::resize(grey, grey, cv::Size(analysis_width, std::max(1, grey.rows * analysis_width / grey.cols)),
               0, 0, cv::INTER_AREA);
    const FrameScore score = ScoreFrame(grey, cv::Mat(), o.geometry_select);
    const std::string image = FramePath("geometry", static_cast<int>(i), o.copy_format);
    std::vector<int> params;
    if (o.copy_format == "jpg") params = {cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality};
    RELIT_REQUIRE(cv::imwrite((root / image).string(), out, params), "cannot write ", image);
    const FileFingerprint print = Fingerprint(photos[i].string());
    frames->push_back({{"index", i},
                       {"source_file", photos[i].filename().string()},
                       {"size_bytes", print.size_bytes},
                       {"fnv1a64", print.fnv1a64},
                       {"width_px", out.cols},
                       {"height_px", out.rows},
                       {"sharpness", score.sharpness},
                       {"clipped_fraction", score.clipped_fraction},
                       {"dark_fraction", score.dark_fraction},
                       {"image", image}});
    progress.Advance();
  }
  progress.Finish();
  return {{"type", "photos"},
          {"path", fs::absolute(o.geometry).lexically_normal().string()},
          {"photos", photos.size()}};
}

// The geometry pass (its own session and clock): a video is scored, filtered
// and subsampled like phone V, a folder of photos is taken as is.
void CaptureGeometry(const CaptureOptions& o, const fs::path& root, RunRecord* record,
                     nlohmann::json* capture, int* kept) {
  auto timer = record->Time("geometry");
  nlohmann::json frames = nlohmann::json::array();
  if (fs::is_directory(o.geometry)) {
    (*capture)["inputs"]["geometry"] = CapturePhotos(o, root, &frames);
    (*capture)["rejected_geometry_frames"] = nlohmann::json::array();
  } else {
    AnalysedVideo video = PrepareInput(o.geometry, kGeometryRole, o);
    AnalyseFrames(&video, o, o.geometry_select, "analyse geometry");
    RejectBadFrames(&video.frames, o.geometry_select);
    Subsample(&video.frames, o.geometry_select);
    std::vector<int> sources;
    for (const Candidate& c : video.frames) {
      if (!c.rejection.empty()) continue;
      nlohmann::json j = ScoreJson(c);
      j["index"] = static_cast<int>(sources.size());
      j["image"] = FramePath("geometry", static_cast<int>(sources.size()), o.copy_format);
      frames.push_back(j);
      sources.push_back(c.source_frame);
    }
    RELIT_REQUIRE(!sources.empty(), "no geometry-pass frame left after rejection (",
                  RejectionSummary(video.frames), "): relax geometry_select in the --config file");
    WriteFrames(video, sources, o, root, "geometry", "", "write geometry");
    nlohmann::json input = InputJson(video);
    input["type"] = "video";
    input["clock"] = "own (a separate session, not synchronised)";
    (*capture)["inputs"]["geometry"] = input;
    (*capture)["rejected_geometry_frames"] = RejectedJson(video.frames);
    (*capture)["counts"]["geometry"] = Counts(video.frames);
  }
  *kept = static_cast<int>(frames.size());
  (*capture)["geometry_frames"] = frames;
}

// What frame selection keeps: phone V's source frames and, per kept phone V
// frame, the phone L frames around it.
struct Selection {
  std::vector<int> view_sources;
  std::vector<std::vector<int>> light_of_view;
  std::map<int, int> light_index;  // phone L source frame -> output index
  int light_candidates = 0;        // phone L frames that could be kept (light_min_spacing_s)

  std::vector<int> LightSources() const {
    std::vector<int> sources;
    for (const auto& [source, index] : light_index) sources.push_back(source);
    return sources;
  }
};

// Cheap checks of every input first, so bad input fails before decoding.
void ProbeInputs(const CaptureOptions& options, AnalysedVideo* view, AnalysedVideo* light) {
  ProbeVideo(options.light, kLightRole);  // fail on a bad phone L file before hashing phone V
  *view = PrepareInput(options.view, kViewRole, options);
  *light = PrepareInput(options.light, kLightRole, options);
  RELIT_REQUIRE(view->fingerprint.size_bytes != light->fingerprint.size_bytes ||
                    view->fingerprint.fnv1a64 != light->fingerprint.fnv1a64, "--view ", options.view, " and --light ",
                options.light, " are the same video: phone V (no flash) and phone L (flash on) each "
                "film their own video; give both files");
  if (!options.geometry.empty() && !fs::is_directory(options.geometry)) {
    ProbeVideo(options.geometry, kGeometryRole);
  }
}

// The phone L frames that may be kept (light_min_spacing_s apart) and their
// times on the common clock.
struct LightCandidates {
  std::vector<int> frames;    // indices into the phone L video's frames
  std::vector<double> times_s;
};

// Puts phone L's frames on the common clock (phone V's) and returns the
// candidates among them; fails when the two videos do not overlap.
LightCandidates PutLightOnViewClock(const CaptureOptions& options, const SyncResult& sync,
                                    const AnalysedVideo& view, AnalysedVideo* light) {
  std::vector<double> all_times;
  for (Candidate& c : light->frames) {
    c.time_s = sync.ToViewTime(c.source_time_s);
    all_times.push_back(c.time_s);
  }
  RELIT_REQUIRE(std::is_sorted(all_times.begin(), all_times.end()), "the ", kLightRole, " ",
                options.light, " has frames out of time order; remux it (ffmpeg -i IN -c copy OUT.mp4)");
  LightCandidates candidates;
  candidates.frames = ThinByTime(all_times, options.light_min_spacing_s);
  for (int i : candidates.frames) candidates.times_s.push_back(all_times[i]);
  const std::vector<double>& light_times = candidates.times_s;
  const int per_side = options.light_frames_per_side;
  const bool overlap = std::any_of(view.frames.begin(), view.frames.end(), [&](const Candidate& c) {
    return !LightFramesAround(c.time_s, light_times, per_side).empty();
  });
  RELIT_REQUIRE(overlap, "phone V (", view.frames.front().time_s, " to ", view.frames.back().time_s,
                " s) and phone L (", light_times.front(), " to ", light_times.back(),
                " s on phone V's clock, offset ", sync.offset_s,
                " s) do not overlap in time: check --offset-s, or that ", options.view, " and ",
                options.light, " were filmed together");
  return candidates;
}

// Frame selection on phone V; the phone L frames follow from it.
Selection SelectFrames(const CaptureOptions& options, const LightCandidates& light, AnalysedVideo* view) {
  const int per_side = options.light_frames_per_side;
  const std::vector<double>& light_times = light.times_s;
  RejectBadFrames(&view->frames, options.view_select);
  for (Candidate& c : view->frames) {
    if (c.rejection.empty() && LightFramesAround(c.time_s, light_times, per_side).empty()) {
      c.rejection = kNoLight;
    }
  }
  Subsample(&view->frames, options.view_select);
  Selection selection;
  selection.light_candidates = static_cast<int>(light.frames.size());
  for (const Candidate& c : view->frames) {
    if (!c.rejection.empty()) continue;
    selection.view_sources.push_back(c.source_frame);
    std::vector<int> around = LightFramesAround(c.time_s, light_times, per_side);
    for (int& l : around) l = light.frames[l];
    selection.light_of_view.push_back(around);
    for (int l : around) selection.light_index[l] = 0;
  }
  RELIT_REQUIRE(!selection.view_sources.empty(), "no phone V frame left after rejection (",
                RejectionSummary(view->frames), " of ", view->frames.size(),
                " frames): film again following docs/capture.md, or relax view_select "
                "(min_blur_ratio, max_dark_fraction, max_clipped_fraction) in the --config file");
  int next = 0;
  for (auto& [source, index] : selection.light_index) index = next++;
  spdlog::info("select: phone V {}; phone L: {} frames needed (of {} candidates{})",
               RejectionSummary(view->frames), selection.light_index.size(), light.frames.size(),
               options.light_min_spacing_s > 0
                   ? fmt::format(", at least {} s apart", options.light_min_spacing_s)
                   : std::string());
  return selection;
}

// capture.json without the geometry pass, the options and the timings.
nlohmann::json CaptureJson(const CaptureOptions& options, const AnalysedVideo& view, const AnalysedVideo& light,
                           const SyncResult& sync, const Selection& selection) {
  nlohmann::json capture;
  capture["tool"] = "relit-capture";
  capture["version"] = RelitVersion();
  capture["clock"] = {
      {"common", "phone V's clock: t_view = t_light + sync.offset_s (with sync.drift.corrected: "
                 "t_view = sync.drift.intercept_s + (1 + sync.drift.rate) * t_light)"},
      {"timestamps", "container presentation times in seconds (per frame, never index x fps)"}};
  capture["inputs"] = {{"view", InputJson(view)}, {"light", InputJson(light)}, {"geometry", nullptr}};
  capture["sync"] = sync.ToJson(options.sync);
  capture["linear"] = {{"view_linear", "half EXR, linear RGB with BT.709/sRGB primaries; 1 = "
                                       "SDR white (HLG: reference white, PQ: 203 cd/m^2)"},
                       {"copies", "8-bit sRGB-encoded " + options.copy_format}};
  nlohmann::json view_frames = nlohmann::json::array();
  size_t k = 0;
  for (const Candidate& c : view.frames) {
    if (!c.rejection.empty()) continue;
    nlohmann::json j = ScoreJson(c);
    j["index"] = k;
    j["image"] = FramePath("view", static_cast<int>(k), options.copy_format);
    j["linear"] = FramePath("view_linear", static_cast<int>(k), "exr");
    nlohmann::json lights = nlohmann::json::array();
    for (int l : selection.light_of_view[k]) lights.push_back(selection.light_index.at(l));
    j["light_frames"] = lights;
    view_frames.push_back(j);
    ++k;
  }
  nlohmann::json light_frames = nlohmann::json::array();
  for (const auto& [source, index] : selection.light_index) {
    nlohmann::json j = ScoreJson(light.frames[source]);
    j["index"] = index;
    j["image"] = FramePath("light", index, options.copy_format);
    light_frames.push_back(j);
  }
  capture["view_frames"] = view_frames;
  capture["light_frames"] = light_frames;
  capture["rejected_view_frames"] = RejectedJson(view.frames);
  capture["counts"] = {{"view", Counts(view.frames)},
                       {"light_usable", light.frames.size()},
                       {"light_candidates", selection.light_candidates},
                       {"light_kept", light_frames.size()}};
  capture["geometry_frames"] = nlohmann::json::array();
  return capture;
}

}  // namespace

CaptureSummary RunCaptureImpl(const CaptureOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  StageRun run({"relit-capture", options.out, options.force, {options.view, options.light, options.geometry}, "--out",
                "capture.log", ParseLogLevel(options.log_level)});
  RunRecord& record = run.record();
  record.SetOptions(OptionsToJson(options));
  record.AddInput("view", options.view);
  record.AddInput("light", options.light);
  if (!options.geometry.empty()) record.AddInput("geometry", options.geometry);

  AnalysedVideo view, light;
  run.Step("probe", [&] { ProbeInputs(options, &view, &light); });
  const SyncResult sync = run.Step("sync", [&] { return Synchronise(view.info, light.info, options.sync); });
  run.Step("analyse", [&] {
    AnalyseFrames(&view, options, options.view_select, "analyse view");
    AnalyseFrames(&light, options, options.view_select, "analyse light");
  });
  const LightCandidates light_candidates = PutLightOnViewClock(options, sync, view, &light);
  const Selection selection =
      run.Step("select", [&] { return SelectFrames(options, light_candidates, &view); });
  const std::vector<int> light_sources = selection.LightSources();
  run.Step("write", [&] {
    WriteFrames(view, selection.view_sources, options, run.path(), "view", "view_linear", "write view");
    WriteFrames(light, light_sources, options, run.path(), "light", "", "write light");
  });

  nlohmann::json capture = CaptureJson(options, view, light, sync, selection);
  CaptureSummary summary;
  if (!options.geometry.empty()) {
    CaptureGeometry(options, run.path(), &record, &capture, &summary.geometry_frames_kept);
  }
  capture["options"] = OptionsToJson(options);
  // The only field that differs between reruns with the same inputs.
  capture["timings_s"] = record.ToJson()["timings_s"];
  WriteJsonFile((run.path() / "capture.json").string(), kCaptureKind, kCaptureVersion, capture);
  summary.out_dir = options.out;
  summary.view_frames_decoded = view.frames_decoded;
  summary.view_frames_kept = static_cast<int>(selection.view_sources.size());
  summary.light_frames_kept = static_cast<int>(light_sources.size());
  summary.sync_method = sync.method;
  summary.offset_s = sync.offset_s;
  summary.confidence = sync.confidence;
  summary.seconds = SecondsSince(start);
  record.Set("offset_s", sync.offset_s);
  record.Set("drift_ms_per_min", sync.drift.valid ? nlohmann::json(sync.drift.ms_per_min())
                                                  : nlohmann::json(nullptr));
  record.Set("drift_corrected", sync.drift_corrected);
  record.Set("view_frames_kept", summary.view_frames_kept);
  record.Set("light_frames_kept", summary.light_frames_kept);
  spdlog::info("relit-capture: wrote {} ({} phone V frames, {} phone L frames, {} geometry "
               "frames, offset {:+.6f} s) in {:.1f} s", options.out, summary.view_frames_kept,
               summary.light_frames_kept, summary.geometry_frames_kept, summary.offset_s,
               summary.seconds);
  run.Commit();
  return summary;
}

int RunCapture(int argc, char** argv) {
  CLI::App app{"relit-capture: ingest and synchronise the two phone videos (phone V without "
               "flash, phone L with its flash on) into a workspace capture/ folder. See "
               "docs/capture.md."};
  std::string config, view, light, geometry, out, transfer, log_level;
  double offset_s = 0, max_offset_s = 0, min_confidence = 0;
  int target_frames = 0, max_long_side_px = 0;
  bool allow_partial = false, correct_drift = false;
  app.add_option("--view", view, "phone V video (filmed without flash)");
  app.add_option("--light", light, "phone L video (filmed with the flash on)");
  app.add_option("--geometry", geometry, "optional geometry-pass video or folder of photos");
  app.add_option("--out", out, "output folder, WORKSPACE/capture (replaced atomically)");
  app.add_option("--config", config, "YAML file with capture options (unknown keys are errors)")
      ->check(CLI::ExistingFile);
  auto* offset = app.add_option("--offset-s", offset_s,
                                "manual sync: phone L's start on phone V's clock, seconds "
                                "(t_view = t_light + offset); skips audio sync");
  auto* window = app.add_option("--max-offset-s", max_offset_s, "audio sync search window, seconds");
  auto* confidence = app.add_option("--min-sync-confidence", min_confidence,
                                    "smallest accepted audio sync peak ratio");
  app.add_option("--transfer", transfer, "auto | srgb | gamma2.2 | hlg | pq");
  auto* frames = app.add_option("--target-frames", target_frames, "phone V frames to keep at most");
  auto* long_side = app.add_option("--max-long-side-px", max_long_side_px,
                                   "downscale frames to this long side (0 = keep)");
  app.add_flag("--correct-drift", correct_drift,
               "map phone L times through the fitted clock drift line (sync.correct_drift)");
  app.add_flag("--allow-partial", allow_partial,
               "keep the part of a damaged video before its first decode error");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  bool force = false;
  app.add_flag("--force", force,
               "replace an --out folder that relit-capture did not write (never one holding an input)");
  CLI11_PARSE(app, argc, argv);
  CaptureOptions options = ReadOptionsFile<CaptureOptions>(config);
  if (!view.empty()) options.view = view;
  if (!light.empty()) options.light = light;
  if (!geometry.empty()) options.geometry = geometry;
  if (!out.empty()) options.out = out;
  if (offset->count() > 0) {
    options.sync.offset_s = offset_s;
  }
  if (window->count() > 0) options.sync.max_offset_s = max_offset_s;
  if (confidence->count() > 0) options.sync.min_confidence = min_confidence;
  if (!transfer.empty()) options.transfer = transfer;
  if (frames->count() > 0) {
    options.view_select.target_frames = target_frames;
    if (target_frames > 0) options.view_select.target_fps = 0;
  }
  if (long_side->count() > 0) options.max_long_side_px = max_long_side_px;
  if (allow_partial) options.allow_partial = true;
  if (correct_drift) options.sync.correct_drift = true;
  return RunStageCommand(std::move(options), force, log_level, RunCaptureImpl);
}

}  // namespace relit::capture
