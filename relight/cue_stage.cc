#include "relight/cue_stage.h"

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/capture_file.h"
#include "core/workspace.h"
#include "core/render/cue_renderer.h"
#include "relight/cue_frames.h"
#include "relight/cue_texture_fit.h"
#include "relight/support_plane.h"
#include "relight/support_albedo.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr uint64_t kFnvOffsetBasis = 1469598103934665603ull;

// One FNV-1a step over `n` bytes.
uint64_t Fnv1a(uint64_t hash, const char* bytes, size_t n) {
  for (size_t i = 0; i < n; ++i) hash = (hash ^ static_cast<unsigned char>(bytes[i])) * 1099511628211ull;
  return hash;
}

}  // namespace

uint64_t HashFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in, "cannot read ", path);
  uint64_t hash = kFnvOffsetBasis;
  char buffer[1 << 16];
  while (in) {
    in.read(buffer, sizeof(buffer));
    hash = Fnv1a(hash, buffer, static_cast<size_t>(in.gcount()));
  }
  return hash;
}

uint64_t HashString(const std::string& bytes) { return Fnv1a(kFnvOffsetBasis, bytes.data(), bytes.size()); }

std::string CaptureTransfer(const std::string& workspace_root) {
  const std::string path = CaptureFilePath(workspace_root);
  if (!std::filesystem::exists(path)) return "";
  return ReadCaptureFile(path).inputs.at("view").transfer_used;
}

CuesFile ReadCuesFile(const std::string& path) {
  const json j = ReadJsonFile(path, CuesFile::kKind, CuesFile::kVersion);
  CuesFile file;
  file.camera = IntrinsicsFromJson(JsonField(j, "camera", path), path + ": camera");
  file.mesh = JsonField(j, "mesh", path).get<std::string>();
  if (j.contains("normal_map")) file.normal_map = JsonString(j, "normal_map", path);
  if (j.contains("cue_weights")) file.cue_weights = JsonString(j, "cue_weights", path);
  file.flash_intensity = JsonNumber(j, "flash_intensity", path);
  file.samples_per_pixel = JsonInt(j, "samples_per_pixel", path);
  file.max_depth = JsonInt(j, "max_depth", path);
  nlohmann::json format = nlohmann::json::object();
  for (const char* key : {"input", "bases"}) {
    if (j.contains(key)) format[key] = j[key];
  }
  file.format = CueFormat::FromJson(format, path);
  file.support_plane =
      SupportPlane::FromJson(j.value("support_plane", json()), path, fs::path(path).parent_path().string());
  for (const json& f : JsonField(j, "frames", path)) {
    const std::string where = path + ": frames[" + std::to_string(file.frames.size()) + "]";
    CueFrameRecord r;
    r.name = JsonField(f, "name", where).get<std::string>();
    r.file = JsonField(f, "file", where).get<std::string>();
    r.cam_from_world = Rigid3FromJson(JsonField(f, "cam_from_world", where), where);
    r.light_position_m = Vector3FromJson(JsonField(f, "light_position_m", where), where);
    r.light_reliable = JsonField(f, "light_reliable", where).get<bool>();
    file.frames.push_back(r);
  }
  return file;
}

void WriteCuesFile(const std::string& path, const CuesFile& file) {
  const json frames = JsonList(file.frames, [](const CueFrameRecord& r) {
    return json{{"name", r.name},
                {"file", r.file},
                {"cam_from_world", ToJson(r.cam_from_world)},
                {"light_position_m", ToJson(r.light_position_m)},
                {"light_reliable", r.light_reliable}};
  });
  WriteJsonFile(path, CuesFile::kKind, CuesFile::kVersion,
                {{"camera", ToJson(file.camera)},
                 {"mesh", file.mesh},
                 {"normal_map", file.normal_map},
                 {"cue_weights", file.cue_weights},
                 {"flash_intensity", file.flash_intensity},
                 {"samples_per_pixel", file.samples_per_pixel},
                 {"max_depth", file.max_depth},
                 {"support_plane", file.support_plane.ToJson()},
                 {"channels", file.format.Channels()},
                 {"input", file.format.input},
                 {"bases", file.format.is_sh() ? std::vector<std::string>{} : file.format.bases},
                 {"basis", file.format.LongBasisNames()},
                 {"frames", frames}});
}

namespace {

std::string FrameStem(const std::string& name) {
  return fs::path(name).filename().string();  // "view/000012" -> "000012"
}

// The proxy's normal map as an absolute path ("" = none).
std::string NormalMapPath(const fs::path& root, const CuesFile& cues) {
  return cues.normal_map.empty() ? "" : (root / cues.normal_map).string();
}

// The support plane's albedos measured on the phone V frames
// (support_albedo.h): the table's, unless the options give it (the default
// grey when the frames do not show enough of it lit; a warning says why), and
// the board's albedo map, written into `dir`. Returns the flash's scale the
// paper gave (zero when not measured).
Eigen::Vector3d MeasureSupportAlbedo(const fs::path& root, const fs::path& mesh_path, const CamerasFile& cameras,
                                     const CueStageOptions& options, const fs::path& dir, CuesFile* cues,
                                     RunRecord& record) {
  const bool measure_table = options.table_albedo.empty();
  if (!measure_table) cues->support_plane.table_albedo = Eigen::Vector3d(options.table_albedo.data());
  const bool need_scale = options.secondary_material == "fitted";
  if (!measure_table && !options.board_albedo_map && !need_scale) return Eigen::Vector3d::Zero();
  auto timer = record.Time("support_albedo");
  const auto scene = LoadProxyScene(mesh_path.string(), cues->support_plane, NormalMapPath(root, *cues));
  std::vector<SupportAlbedoFrame> frames;
  for (const CueFrameRecord& r : cues->frames) {
    const CalibratedFrame* frame = cameras.Find(r.name);
    if (frame == nullptr || frame->image_linear.empty()) continue;
    frames.push_back({cameras.ViewCamera(*frame), r.light_position_m, (root / frame->image_linear).string()});
  }
  SupportAlbedoOptions measure;
  measure.board_texel_m = options.board_albedo_map ? options.board_albedo_texel_m : 0.0;
  const SupportAlbedoEstimate estimate = EstimateSupportAlbedo(*scene, cues->support_plane, frames, measure);
  record.Set("support_albedo_frames", estimate.frames_used);
  if (measure_table) {
    const Eigen::Vector3d albedo =
        estimate.found ? estimate.table_albedo : Eigen::Vector3d::Constant(kDefaultTableAlbedo);
    if (estimate.found) {
      spdlog::info("cues: table albedo {:.3f} {:.3f} {:.3f} (linear RGB, {} lit pixels in {} frames against the "
                   "paper)", albedo.x(), albedo.y(), albedo.z(), estimate.table_pixels, estimate.frames_used);
    } else {
      spdlog::warn("cues: the table's albedo could not be measured ({}); using {} (set cues.table_albedo)",
                   estimate.reason, kDefaultTableAlbedo);
    }
    record.Set("table_albedo_pixels", estimate.table_pixels);
    record.Set("table_albedo", std::vector<double>{albedo.x(), albedo.y(), albedo.z()});
    cues->support_plane.table_albedo = albedo;
  }
  if (need_scale) record.Set("flash_scale", std::vector<double>{estimate.flash_scale.x(), estimate.flash_scale.y(),
                                                                estimate.flash_scale.z()});
  if (!options.board_albedo_map) return estimate.flash_scale;
  if (estimate.board_albedo.empty()) {
    spdlog::warn("cues: the board's albedo map could not be measured (no frame shows enough lit paper); the cues "
                 "assume the bare print");
    return estimate.flash_scale;
  }
  const fs::path map_path = dir / "support_albedo.exr";
  WriteImage(map_path.string(), estimate.board_albedo);
  cues->support_plane.albedo_map = map_path.string();
  spdlog::info("cues: board albedo map {}x{} ({:.0f}% of its texels measured, the print elsewhere)",
               estimate.board_albedo.width(), estimate.board_albedo.height(),
               100 * estimate.board_measured_fraction);
  record.Set("board_albedo_measured_fraction", estimate.board_measured_fraction);
  return estimate.flash_scale;
}

// Renders every frame of `cues` missing in `dir` (a frame already there is
// kept from an interrupted run) on `scene`.
void RenderFrames(render::Scene& scene, const CuesFile& cues, const CamerasFile& cameras,
                  const CueStageOptions& options, const fs::path& dir, const char* label, CueStageSummary* summary) {
  Progress progress(label, static_cast<int64_t>(cues.frames.size()));
  for (size_t i = 0; i < cues.frames.size(); ++i) {
    const CueFrameRecord& r = cues.frames[i];
    const fs::path file = dir / fs::path(r.file).filename();
    if (fs::exists(file)) {
      ++summary->frames_reused;
    } else {
      const Camera camera(cameras.undistorted_view, r.cam_from_world);
      const Image frame = RenderCueFrame(scene, camera, CueLight::Point(r.light_position_m, options.flash_intensity),
                                         CueFrameRenderSettings(options, i), cues.format);
      WriteImage(file.string(), frame);  // atomic per file
      ++summary->frames_rendered;
    }
    progress.Advance();
  }
  progress.Finish();
}

// cues.secondary_material fitted: the cue fit (cue_texture_fit.h) of the
// frames rendered with the basis in `first_dir`, on every frame with an
// image, a matte and a reliable flash, its weights divided by the flash's
// scale (reflectances, as the support plane's albedos), written to `path`.
void FitProxyCueWeights(const fs::path& root, const CuesFile& cues, const CamerasFile& cameras,
                        const ProxyFile& proxy, const CueStageOptions& options, const fs::path& first_dir,
                        const Eigen::Vector3d& flash_scale, const fs::path& path, RunRecord& record) {
  auto timer = record.Time("fit_secondary_material");
  CueFitOptions fit_options;
  fit_options.saturation_level = ResolveSaturationLevel(fit_options.saturation_level, CaptureTransfer(root.string()));
  CueTextureFit fit(options.secondary_fit_resolution_px, fit_options);
  int frames = 0;
  Progress progress("cues: fit the secondary material", static_cast<int64_t>(cues.frames.size()));
  for (const CueFrameRecord& r : cues.frames) {
    const CalibratedFrame* frame = cameras.Find(r.name);
    const ViewMatte* matte = proxy.Find(r.name);
    if (r.light_reliable && frame != nullptr && !frame->image_linear.empty() && matte != nullptr) {
      fit.AddFrame(ReadCueFrame((first_dir / fs::path(r.file).filename()).string()),
                   ReadImage((root / frame->image_linear).string()), ReadImage((root / matte->matte).string()));
      ++frames;
    }
    progress.Advance();
  }
  progress.Finish();
  RELIT_REQUIRE(frames > 0, "cues: secondary_material fitted found no phone V frame with an image, a matte and a "
                "reliable flash to fit; set cues.secondary_material: basis");
  const CueFitStats stats = fit.Solve();
  const int res = fit.resolution();
  Image weights(res, res, render::CueChannelNames(CueTextureFit::kBases));
  for (int y = 0; y < res; ++y) {
    for (int x = 0; x < res; ++x) {
      for (int c = 0; c < 3; ++c) {
        // Reflectances; a texel's bases reflect at most all the light (noise
        // in a fit must not make the bounces gain energy).
        float sum = 0;
        for (int k = 0; k < CueTextureFit::kBases; ++k) {
          sum += weights.at(x, y, 3 * k + c) =
              std::max(0.0f, fit.Weight(x, y, 3 * k + c)) / static_cast<float>(flash_scale[c]);
        }
        if (sum > 1) {
          for (int k = 0; k < CueTextureFit::kBases; ++k) weights.at(x, y, 3 * k + c) /= sum;
        }
      }
    }
  }
  WriteImage(path.string(), weights, PixelStorage::kFloat);
  record.Set("secondary_fit", stats.ToJson());
  record.Set("secondary_fit_frames", frames);
  spdlog::info("cues: secondary material fitted on {} frames ({} pixels, rms residual {:.4f}) -> {}", frames,
               stats.pixels, stats.rms_residual, path.string());
}

}  // namespace

CueRenderSettings CueFrameRenderSettings(const CueStageOptions& options, size_t index) {
  CueRenderSettings settings;
  settings.samples_per_pixel = options.samples_per_pixel;
  settings.max_depth = options.max_depth;
  settings.denoise = options.denoise;
  settings.seed = options.seed * 1000003ull + index;
  return settings;
}

CueStageSummary RunCueStage(const std::string& workspace, const CueStageOptions& options,
                            RunRecord& record) {
  CheckOptions(options, "cues");
  const fs::path root(workspace);
  const fs::path cameras_path = root / "calib" / "cameras.json";
  const fs::path lights_path = root / "calib" / "lights.json";
  const fs::path proxy_path = root / "reconstruct" / "proxy.json";
  for (const fs::path& p : {cameras_path, lights_path}) {
    RELIT_REQUIRE(fs::exists(p), p.string(), " is missing: run the calib stage first (relit-calib)");
  }
  RELIT_REQUIRE(fs::exists(proxy_path), proxy_path.string(),
                " is missing: run the reconstruct stage first (relit-reconstruct)");
  record.AddInput("cameras", cameras_path.string());
  record.AddInput("lights", lights_path.string());
  record.AddInput("proxy", proxy_path.string());
  const CamerasFile cameras = ReadCamerasFile(cameras_path.string());
  const LightsFile lights = ReadLightsFile(lights_path.string());
  const ProxyFile proxy = ReadProxyFile(proxy_path.string());
  const fs::path mesh_path = root / proxy.mesh;

  CuesFile cues;
  cues.camera = cameras.undistorted_view;
  cues.mesh = proxy.mesh;
  cues.normal_map = proxy.normal_map;
  cues.flash_intensity = options.flash_intensity;
  cues.samples_per_pixel = options.samples_per_pixel;
  cues.max_depth = options.max_depth;
  cues.format = options.Format();
  int without_light = 0;
  for (const CalibratedFrame* frame : cameras.FramesOf("view")) {
    const FrameLight* light = lights.Find(frame->name);
    if (light == nullptr) {
      ++without_light;
      continue;
    }
    CueFrameRecord r;
    r.name = frame->name;
    r.file = "relight/cues/" + FrameStem(frame->name) + ".exr";
    r.cam_from_world = frame->cam_from_world;
    r.light_position_m = light->position_m;
    r.light_reliable = light->reliable;
    cues.frames.push_back(r);
  }
  RELIT_REQUIRE(!cues.frames.empty(), cameras_path.string(), " and ", lights_path.string(),
                " have no phone V frame with a flash position: nothing to render cues for "
                "(check calib_report.json: were phone L frames registered?)");
  if (without_light > 0) spdlog::warn("cues: {} phone V frames have no flash position and are skipped", without_light);

  // Resume only with identical inputs and options.
  json fingerprint = {{"options", OptionsToJson(options)},
                      {"cameras", HashFile(cameras_path.string())},
                      {"lights", HashFile(lights_path.string())},
                      {"mesh", HashFile(mesh_path.string())},
                      {"normal_map", cues.normal_map.empty() ? 0 : HashFile(NormalMapPath(root, cues))}};
  if (options.secondary_material == "fitted") fingerprint["proxy"] = HashFile(proxy_path.string());  // its mattes
  const fs::path partial = root / "relight" / ".cues.partial";
  const fs::path fingerprint_path = partial / "fingerprint.json";
  bool resume = false;
  if (fs::exists(fingerprint_path)) {
    std::ifstream in(fingerprint_path);
    json previous = json::parse(in, nullptr, false);
    resume = !previous.is_discarded() && previous == fingerprint;
  }
  if (!resume) {
    fs::remove_all(partial);
    fs::create_directories(partial);
    std::ofstream(fingerprint_path) << fingerprint.dump(2);
  } else {
    spdlog::info("cues: continuing an interrupted run in {}", partial.string());
  }

  std::unique_ptr<tbb::global_control> threads;
  if (options.threads > 0) {
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    options.threads);
  }
  Eigen::Vector3d flash_scale = Eigen::Vector3d::Zero();
  if (options.support_plane) {
    cues.support_plane.enabled = true;
    cues.support_plane.board = cameras.board;
    cues.support_plane.paper_albedo = options.paper_albedo;
    cues.support_plane.ink_albedo = options.ink_albedo;
    cues.support_plane.paper_margin_m = options.paper_margin_m;
    cues.support_plane.table_half_size_m = std::max(1.5, 20 * proxy.object_radius_m);
    flash_scale = MeasureSupportAlbedo(root, mesh_path, cameras, options, partial, &cues, record);
    cues.support_plane.Check(cameras_path.string());
  }
  bool fitted = options.secondary_material == "fitted";
  CueStageSummary summary;
  if (fitted && !(flash_scale.minCoeff() > 0)) {
    spdlog::warn("cues: secondary_material fitted needs the flash's scale from the board's paper, which no frame "
                 "shows lit: the proxy wears the basis past the primary hit");
    fitted = false;
  }
  record.Set("secondary_material", fitted ? "fitted" : "basis");
  const fs::path weights_path = partial / "proxy_cue_weights.exr";
  if (fitted) {
    // The frames rendered with the basis first (kept in `first_dir` until the fit is written).
    const fs::path first_dir = partial / "basis";
    if (!fs::exists(weights_path)) {
      fs::create_directories(first_dir);
      auto scene = LoadProxyScene(mesh_path.string(), cues.support_plane, NormalMapPath(root, cues));
      {
        auto timer = record.Time("render_basis_cues");
        RenderFrames(*scene, cues, cameras, options, first_dir, "cues (basis)", &summary);
      }
      FitProxyCueWeights(root, cues, cameras, proxy, options, first_dir, flash_scale, weights_path, record);
    }
    fs::remove_all(first_dir);
    cues.cue_weights = "relight/cues/" + weights_path.filename().string();  // partial/ becomes cues/
  }
  auto scene = LoadProxyScene(mesh_path.string(), cues.support_plane, NormalMapPath(root, cues),
                              fitted ? weights_path.string() : "");
  {
    auto timer = record.Time("render_cues");
    RenderFrames(*scene, cues, cameras, options, partial, "cues", &summary);
  }
  WriteCuesFile((partial / "cues.json").string(), cues);
  fs::remove(fingerprint_path);
  record.Set("frames", static_cast<int>(cues.frames.size()));
  record.Set("frames_rendered", summary.frames_rendered);
  record.Set("frames_reused", summary.frames_reused);
  record.Write((partial / "run.json").string());
  const fs::path target = root / "relight" / "cues";
  fs::remove_all(target);
  fs::rename(partial, target);
  spdlog::info("cues: {} frames ({} renders, {} kept from an interrupted run; past the primary hit the proxy wears "
               "{}) -> {}", cues.frames.size(), summary.frames_rendered, summary.frames_reused,
               fitted ? "its fitted material" : "the basis", target.string());
  return summary;
}

}  // namespace relit::relight
