#include "reconstruct/reconstruct.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <optional>
#include <utility>

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "core/atomic_output.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/render/scene.h"
#include "core/run_record.h"
#include "core/stage_cli.h"
#include "core/stage_run.h"
#include "core/workspace.h"
#include "reconstruct/closed_form_matting.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/light_views.h"
#include "reconstruct/proxy_normals.h"
#include "reconstruct/proxy_source.h"
#include "reconstruct/silhouette_refine.h"
#include "reconstruct/surface_photo_refine.h"
#include "reconstruct/trimap.h"
#include "reconstruct/uv_atlas.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

constexpr const char* kReportKind = "reconstruct_report";
constexpr int kReportVersion = 1;

std::string FileStem(const std::string& frame_name) {
  std::string stem = frame_name;
  std::replace(stem.begin(), stem.end(), '/', '_');
  return stem;
}

// The phone V frames calib undistorted: the ones a matte can be made for.
std::vector<const CalibratedFrame*> UndistortedViewFrames(const CamerasFile& cameras, const std::string& cameras_path) {
  std::vector<const CalibratedFrame*> frames;
  for (const CalibratedFrame* f : cameras.FramesOf("view")) {
    if (!f->image_8bit.empty()) frames.push_back(f);
  }
  RELIT_REQUIRE(!frames.empty(), "reconstruct: ", cameras_path, " has no phone V frame with an undistorted image");
  return frames;
}

// calib's flash positions (recorded as an input), or nothing: then the
// step that needs them logs why it is skipped and reports it under
// `report_key`.
std::optional<LightsFile> FlashPositions(const fs::path& workspace, RunRecord& record, const std::string& step,
                                         const std::string& consequence, const std::string& report_key,
                                         nlohmann::json* report) {
  const fs::path lights_path = workspace / "calib" / "lights.json";
  if (!fs::exists(lights_path)) {
    spdlog::info("{}: {} is missing (no flash positions); {}", step, lights_path.string(), consequence);
    (*report)[report_key] = {{"skipped", "no calib/lights.json"}};
    return std::nullopt;
  }
  record.AddInput("lights", lights_path.string());
  return ReadLightsFile(lights_path.string());
}

// 1d. The proxy's outlines against the object's in the flash-lit phone V
// frames (silhouette_refine.h); needs the flash positions.
void RefineOutlines(const fs::path& workspace, const CamerasFile& cameras, const ReconstructOptions& options,
                    RunRecord& record, render::TriangleMesh* proxy, nlohmann::json* report) {
  const SilhouetteOptions& silhouette = options.refine.silhouette;
  if (!silhouette.enabled || silhouette.rounds == 0) return;
  const std::optional<LightsFile> lights =
      FlashPositions(workspace, record, "silhouette refine", "skipped", "refine_silhouette", report);
  if (!lights) return;
  std::vector<SilhouetteView> views;
  for (const CalibratedFrame* frame : cameras.FramesOf("view")) {
    const FrameLight* light = lights->Find(frame->name);
    if (light == nullptr || !light->reliable || frame->image_linear.empty()) continue;
    const std::string path = (workspace / frame->image_linear).string();
    views.push_back({cameras.ViewCamera(*frame), light->position_m, [path] { return ReadImage(path); }});
  }
  if (views.empty()) {
    spdlog::info("silhouette refine: no phone V frame with a reliable flash position; skipped");
    (*report)["refine_silhouette"] = {{"skipped", "no phone V frame with a reliable flash position"}};
    return;
  }
  auto timer = record.Time("refine_silhouette");
  SilhouetteReport silhouette_report;
  *proxy = RefineSilhouettes(*proxy, views, BoardPrint(cameras.board), silhouette, options.cleanup.crop_margin_m,
                             &silhouette_report);
  if (options.cleanup.remove_self_intersections) {
    silhouette_report.self_intersection_faces_replaced =
        RemoveSelfIntersections(proxy, options.cleanup.self_intersection_rounds);
  }
  (*report)["refine_silhouette"] = silhouette_report.ToJson();
}

// 1. The proxy mesh: loaded, or built from the images; cleaned up, then
// refined against the depth maps when the build made any.
render::TriangleMesh BuildProxy(const fs::path& workspace, const CamerasFile& cameras, const CropRegion& crop,
                                const ReconstructOptions& options, StageRun& run, nlohmann::json* report) {
  RunRecord& record = run.record();
  render::TriangleMesh input;
  const bool refine = options.refine.enabled && options.refine.iterations > 0;
  DepthEvidence evidence;  // only gathered when the refinement will use it
  if (options.proxy.method == "mesh") {
    record.AddInput("mesh", options.mesh);
    auto timer = record.Time("load_mesh");
    input = render::LoadMesh(options.mesh);
    input.Check(options.mesh + " (--mesh)");  // name the file, not just "input mesh"
    (*report)["proxy"] = {{"method", "mesh"}, {"mesh", options.mesh}};
  } else {
    nlohmann::json proxy_report;
    input = BuildProxyFromImages(workspace, cameras, crop, options.proxy, run.path() / "proxy_points", &record,
                                 &proxy_report, refine ? &evidence : nullptr);
    (*report)["proxy"] = proxy_report;
    record.Set("proxy_method", proxy_report["method"]);
  }
  CleanupReport cleanup_report;
  render::TriangleMesh proxy =
      run.Step("cleanup", [&] { return CleanupMesh(input, options.cleanup, crop, &cleanup_report); });
  (*report)["cleanup"] = cleanup_report.ToJson();
  if (!refine) return proxy;
  if (evidence.empty()) {
    spdlog::info("refine: skipped (the {} proxy has no depth maps to refine against)", options.proxy.method);
    (*report)["refine"] = {{"skipped", "no depth maps (proxy.method " + options.proxy.method + ")"}};
    return proxy;
  }
  auto timer = record.Time("refine");
  RefineReport refine_report;
  proxy = RefineWithDepthMaps(proxy, evidence, options.refine, options.cleanup.crop_margin_m, &refine_report);
  if (options.cleanup.remove_self_intersections) {  // moving vertices can fold the surface again
    refine_report.self_intersection_faces_replaced =
        RemoveSelfIntersections(&proxy, options.cleanup.self_intersection_rounds);
  }
  (*report)["refine"] = refine_report.ToJson();
  const SurfacePhotoOptions& photometric = options.refine.photometric;
  if (photometric.enabled && photometric.rounds > 0) {
    auto photo_timer = record.Time("refine_photometric");
    SurfacePhotoReport photo_report;
    std::vector<Camera> photo_cameras = std::move(evidence.cameras);
    std::vector<cv::Mat> photo_grays = std::move(evidence.grays);
    if (photometric.light_frames) {
      LightViews light = LoadLightViews(workspace, cameras, options.proxy.max_frames);
      if (!light.cameras.empty()) record.AddInput("capture", CaptureFilePath(workspace.string()));
      spdlog::info("surface photometric refine: {} phone L frames vote beside {} phone V frames",
                   light.cameras.size(), photo_cameras.size());
      photo_cameras.insert(photo_cameras.end(), light.cameras.begin(), light.cameras.end());
      photo_grays.insert(photo_grays.end(), light.grays.begin(), light.grays.end());
    }
    proxy = RefineSurfacePhotometric(proxy, photo_cameras, photo_grays, photometric,
                                     options.cleanup.crop_margin_m, &photo_report);
    if (options.cleanup.remove_self_intersections) {
      photo_report.self_intersection_faces_replaced =
          RemoveSelfIntersections(&proxy, options.cleanup.self_intersection_rounds);
    }
    (*report)["refine_photometric"] = photo_report.ToJson();
  }
  RefineOutlines(workspace, cameras, options, record, &proxy, report);
  return proxy;
}

// The UV atlas and proxy.obj (+ the preview); proxy.json's mesh fields.
ProxyFile WriteProxyMesh(const render::TriangleMesh& proxy, const ReconstructOptions& options, StageRun& run,
                         ReconstructSummary* summary, nlohmann::json* report) {
  AtlasStats atlas_stats;
  const UvAtlas atlas = run.Step("atlas", [&] { return BuildAtlas(proxy, options.atlas, &atlas_stats); });
  WriteObjWithAtlas((run.path() / "proxy.obj").string(), proxy, atlas);
  if (options.atlas.write_preview) {
    WriteImage((run.path() / "atlas_preview.png").string(), AtlasPreview(proxy, atlas), PixelStorage::kUint8);
  }
  ProxyFile proxy_file;
  proxy_file.mesh = "reconstruct/proxy.obj";
  proxy_file.atlas_resolution_px = options.atlas.resolution_px;
  const Eigen::AlignedBox3f bounds = proxy.Bounds();
  proxy_file.object_centre_m = bounds.center().cast<double>();
  for (const Eigen::Vector3f& p : proxy.positions) {
    proxy_file.object_radius_m = std::max(proxy_file.object_radius_m, (p.cast<double>() - proxy_file.object_centre_m).norm());
  }
  (*report)["atlas"] = atlas_stats.ToJson();
  summary->charts = atlas.chart_count;
  summary->atlas_utilisation = atlas_stats.utilisation;
  return proxy_file;
}

// The trimap and closed-form matte of one frame; false (and a note in the
// frame's report) where the proxy is not visible.
bool MatteFrame(const fs::path& workspace, const fs::path& root, const CamerasFile& cameras,
                const CalibratedFrame& frame, const render::Scene& scene, const Eigen::Vector3d& object_centre_m,
                const ReconstructOptions& options, nlohmann::json* report) {
  const Camera camera = cameras.ViewCamera(frame);
  const cv::Mat silhouette = ProjectSilhouette(scene, camera);
  nlohmann::json& fr = *report;
  fr["view_frame"] = frame.name;
  if (cv::countNonZero(silhouette) == 0) {
    spdlog::warn("{}: the proxy is not visible; no matte", frame.name);
    fr["skipped"] = "proxy not visible";
    return false;
  }
  const double depth = (camera.cam_from_world() * object_centre_m).z();
  const int band = TrimapBandPx(options.trimap, camera.intrinsics(), depth);
  const cv::Mat trimap = MakeTrimap(silhouette, band);
  const Image image = ReadImage((workspace / frame.image_8bit).string());
  RELIT_REQUIRE(image.width() == silhouette.cols && image.height() == silhouette.rows && image.channels() >= 3,
                "reconstruct: ", frame.image_8bit, " is ", image.width(), "x", image.height(), "x",
                image.channels(), ", the undistorted camera is ", silhouette.cols, "x", silhouette.rows);
  const cv::Mat colour = image.SelectChannels(std::vector<int>{0, 1, 2}).ToMat();
  cv::Mat prior;
  silhouette.convertTo(prior, CV_32F, 1.0 / 255.0);
  MatteStats stats;
  const cv::Mat alpha = SolveClosedFormMatte(colour, trimap, prior, options.matting, &stats);
  const std::string stem = FileStem(frame.name);
  Image trimap_image = Image::FromMat(trimap);
  trimap_image.set_channel_names({"Y"});
  WriteImage((root / "trimaps" / (stem + ".png")).string(), trimap_image, PixelStorage::kUint8);
  Image matte_image = Image::FromMat(alpha);
  matte_image.set_channel_names({"A"});
  WriteImage((root / "mattes" / (stem + ".png")).string(), matte_image, PixelStorage::kUint16);
  fr["band_px"] = band;
  fr["unknown_px"] = stats.unknown_px;
  fr["levels"] = stats.levels;
  fr["seconds"] = stats.seconds;
  return true;
}

// 2. Trimaps and mattes, in parallel over frames; their paths go into
// proxy.json, the frames' reports into reconstruct_report.json.
void WriteMattes(const fs::path& workspace, const CamerasFile& cameras, const std::vector<const CalibratedFrame*>& frames,
                 const render::TriangleMesh& proxy, const ReconstructOptions& options, StageRun& run,
                 ProxyFile* proxy_file, ReconstructSummary* summary, nlohmann::json* report) {
  render::Scene scene;
  scene.AddObject(proxy, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();
  const std::vector<const CalibratedFrame*> matte_frames = Subsample(frames, options.max_matte_frames);
  const fs::path root = run.path();
  fs::create_directories(root / "mattes");
  fs::create_directories(root / "trimaps");
  std::vector<nlohmann::json> frame_reports(matte_frames.size());
  std::vector<bool> matted(matte_frames.size(), false);
  run.Step("mattes", [&] {
    std::unique_ptr<tbb::global_control> threads;
    if (options.matting.threads > 0) {
      threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      options.matting.threads);
    }
    Progress progress("mattes", static_cast<int64_t>(matte_frames.size()));
    tbb::parallel_for(size_t(0), matte_frames.size(), [&](size_t i) {
      matted[i] = MatteFrame(workspace, root, cameras, *matte_frames[i], scene, proxy_file->object_centre_m, options,
                             &frame_reports[i]);
      progress.Advance();
    });
  });
  for (size_t i = 0; i < matte_frames.size(); ++i) {
    if (!matted[i]) {
      ++summary->skipped_frames;
      continue;
    }
    const std::string stem = FileStem(matte_frames[i]->name);
    proxy_file->mattes.push_back({matte_frames[i]->name, "reconstruct/mattes/" + stem + ".png",
                                  "reconstruct/trimaps/" + stem + ".png"});
  }
  RELIT_REQUIRE(!proxy_file->mattes.empty(), "reconstruct: the proxy is not visible in any phone V frame; "
                "is the mesh in the board frame (metres, +Z up)?");
  (*report)["frames"] = frame_reports;
}

// 3. The photometric-stereo normal map (proxy_normals.h) of the proxy as
// written (with its atlas), when the flash positions are known.
void WriteNormalMap(const fs::path& workspace, const CamerasFile& cameras,
                    const std::vector<const CalibratedFrame*>& frames, const NormalMapOptions& options,
                    StageRun& run, ProxyFile* proxy_file, nlohmann::json* report) {
  if (!options.enabled) return;
  const std::optional<LightsFile> lights = FlashPositions(
      workspace, run.record(), "normal map", "the proxy keeps its mesh normals", "normal_map", report);
  if (!lights) return;
  const render::TriangleMesh mesh = render::LoadMesh((run.path() / "proxy.obj").string());
  NormalMapStats stats;
  Image map = run.Step("normal_map", [&] {
    return EstimateNormalMap(workspace.string(), cameras, *lights, frames, mesh, options, &stats);
  });
  map.set_channel_names({"R", "G", "B"});
  WriteImage((run.path() / "proxy_normals.exr").string(), map, PixelStorage::kFloat);
  proxy_file->normal_map = "reconstruct/proxy_normals.exr";
  (*report)["normal_map"] = stats.ToJson();
}

}  // namespace

ReconstructSummary RunReconstructImpl(const ReconstructOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  const fs::path workspace(options.workspace);
  const std::string cameras_path = (workspace / "calib" / "cameras.json").string();
  const CamerasFile cameras = ReadCamerasFile(cameras_path);
  const std::vector<const CalibratedFrame*> frames = UndistortedViewFrames(cameras, cameras_path);
  StageRun run({"relit-reconstruct", workspace / "reconstruct", options.force, {options.mesh}, "--workspace",
                "reconstruct.log", ParseLogLevel(options.log_level)});
  run.record().SetOptions(OptionsToJson(options));
  run.record().AddInput("cameras", cameras_path);
  nlohmann::json report;
  ReconstructSummary summary;

  const CropRegion crop = CropFromCameras(cameras, frames, options.cleanup);
  spdlog::info("crop: centre ({:.3f}, {:.3f}) m, radius {:.3f} m, above z = {:.4f} m", crop.centre_xy.x(),
               crop.centre_xy.y(), crop.radius_m, options.cleanup.crop_margin_m);
  const render::TriangleMesh proxy = BuildProxy(workspace, cameras, crop, options, run, &report);
  const MeshStats mesh_stats = AnalyseMesh(proxy);
  if (!mesh_stats.closed() || !mesh_stats.manifold()) {
    spdlog::warn("proxy: {} boundary edges, {} non-manifold edges, {} non-manifold vertices after cleanup",
                 mesh_stats.boundary_edges, mesh_stats.non_manifold_edges, mesh_stats.non_manifold_vertices);
  }
  ProxyFile proxy_file = WriteProxyMesh(proxy, options, run, &summary, &report);
  WriteMattes(workspace, cameras, frames, proxy, options, run, &proxy_file, &summary, &report);
  WriteNormalMap(workspace, cameras, frames, options.normal_map, run, &proxy_file, &report);
  WriteProxyFile((run.path() / "proxy.json").string(), proxy_file);

  report["mesh"] = mesh_stats.ToJson();
  report["crop"] = {{"centre_xy_m", {crop.centre_xy.x(), crop.centre_xy.y()}}, {"radius_m", crop.radius_m}};
  WriteJsonFile((run.path() / "reconstruct_report.json").string(), kReportKind, kReportVersion, report);

  summary.faces = static_cast<int>(proxy.triangles.size());
  summary.mattes = static_cast<int>(proxy_file.mattes.size());
  summary.seconds = SecondsSince(start);
  RunRecord& record = run.record();
  record.Set("faces", summary.faces);
  record.Set("charts", summary.charts);
  record.Set("atlas_utilisation", summary.atlas_utilisation);
  record.Set("mattes", summary.mattes);
  record.Set("skipped_frames", summary.skipped_frames);
  spdlog::info("reconstruct: {} faces, {} charts ({:.1f}% of the atlas), {} mattes in {:.1f} s", summary.faces,
               summary.charts, 100 * summary.atlas_utilisation, summary.mattes, summary.seconds);
  run.Commit();
  summary.out_dir = run.target().string();
  return summary;
}

int RunReconstruct(int argc, char** argv) {
  CLI::App app{"relit-reconstruct: proxy mesh (cleanup, UV atlas), trimaps and closed-form alpha mattes. "
               "Reads W/calib/cameras.json, writes W/reconstruct. See docs/reconstruct.md."};
  StageCommandLine cli("reconstruct", "reads W/calib, writes W/reconstruct");
  std::string mesh;
  cli.AddWorkspaceAndConfig(app);
  app.add_option("--mesh", mesh, "user-supplied proxy mesh (OBJ/PLY, board frame, metres); sets proxy.method: mesh")
      ->check(CLI::ExistingFile);
  std::string method;
  app.add_option("--proxy-method", method, "dense (default) | sparse | mesh (see docs/reconstruct.md)");
  cli.AddLogLevelAndForce(app);
  CLI11_PARSE(app, argc, argv);
  ReconstructOptions options = cli.ReadOptions<ReconstructOptions>();
  if (!mesh.empty()) {
    options.mesh = mesh;
    options.proxy.method = "mesh";
  }
  if (!method.empty()) options.proxy.method = method;
  return cli.RunStage(std::move(options), RunReconstructImpl);
}

}  // namespace relit::reconstruct
