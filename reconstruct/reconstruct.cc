#include "reconstruct/reconstruct.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>

#include <CLI/CLI.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/render/scene.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "reconstruct/closed_form_matting.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/proxy_source.h"
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

}  // namespace

ReconstructSummary RunReconstructImpl(const ReconstructOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  const spdlog::level::level_enum level = ParseLogLevel(options.log_level);
  const fs::path workspace(options.workspace);
  const std::string cameras_path = (workspace / "calib" / "cameras.json").string();
  const CamerasFile cameras = ReadCamerasFile(cameras_path);
  std::vector<const CalibratedFrame*> frames;
  for (const CalibratedFrame* f : cameras.FramesOf("view")) {
    if (!f->image_8bit.empty()) frames.push_back(f);
  }
  RELIT_REQUIRE(!frames.empty(), "reconstruct: ", cameras_path, " has no phone V frame with an undistorted image");

  AtomicDir out(workspace / "reconstruct", OutputGuard{"relit-reconstruct", options.force, {options.mesh}},
                "--workspace");
  const fs::path root = out.path();
  LogFileScope log_scope((root / "reconstruct.log").string(), level);
  RunRecord record("relit-reconstruct");
  record.SetOptions(OptionsToJson(options));
  record.AddInput("cameras", cameras_path);
  nlohmann::json report;
  ReconstructSummary summary;

  // 1. Proxy mesh.
  const CropRegion crop = CropFromCameras(cameras, frames, options.cleanup);
  spdlog::info("crop: centre ({:.3f}, {:.3f}) m, radius {:.3f} m, above z = {:.4f} m", crop.centre_xy.x(),
               crop.centre_xy.y(), crop.radius_m, options.cleanup.crop_margin_m);
  render::TriangleMesh input;
  const bool refine = options.refine.enabled && options.refine.iterations > 0;
  DepthEvidence evidence;  // only gathered when the refinement will use it
  if (options.proxy.method == "mesh") {
    record.AddInput("mesh", options.mesh);
    auto timer = record.Time("load_mesh");
    input = render::LoadMesh(options.mesh);
    input.Check(options.mesh + " (--mesh)");  // name the file, not just "input mesh"
    report["proxy"] = {{"method", "mesh"}, {"mesh", options.mesh}};
  } else {
    nlohmann::json proxy_report;
    input = BuildProxyFromImages(workspace, cameras, crop, options.proxy, root / "proxy_points", &record,
                                 &proxy_report, refine ? &evidence : nullptr);
    report["proxy"] = proxy_report;
    record.Set("proxy_method", proxy_report["method"]);
  }
  CleanupReport cleanup_report;
  render::TriangleMesh proxy;
  {
    auto timer = record.Time("cleanup");
    proxy = CleanupMesh(input, options.cleanup, crop, &cleanup_report);
  }
  if (refine) {
    if (evidence.empty()) {
      spdlog::info("refine: skipped (the {} proxy has no depth maps to refine against)", options.proxy.method);
      report["refine"] = {{"skipped", "no depth maps (proxy.method " + options.proxy.method + ")"}};
    } else {
      auto timer = record.Time("refine");
      RefineReport refine_report;
      proxy = RefineWithDepthMaps(proxy, evidence, options.refine, options.cleanup.crop_margin_m, &refine_report);
      if (options.cleanup.remove_self_intersections) {  // moving vertices can fold the surface again
        refine_report.self_intersection_faces_replaced =
            RemoveSelfIntersections(&proxy, options.cleanup.self_intersection_rounds);
      }
      report["refine"] = refine_report.ToJson();
    }
  }
  evidence = DepthEvidence{};  // free the depth maps before matting
  const MeshStats mesh_stats = AnalyseMesh(proxy);
  if (!mesh_stats.closed() || !mesh_stats.manifold()) {
    spdlog::warn("proxy: {} boundary edges, {} non-manifold edges, {} non-manifold vertices after cleanup",
                 mesh_stats.boundary_edges, mesh_stats.non_manifold_edges, mesh_stats.non_manifold_vertices);
  }
  AtlasStats atlas_stats;
  UvAtlas atlas;
  {
    auto timer = record.Time("atlas");
    atlas = BuildAtlas(proxy, options.atlas, &atlas_stats);
  }
  WriteObjWithAtlas((root / "proxy.obj").string(), proxy, atlas);
  if (options.atlas.write_preview) WriteImage((root / "atlas_preview.png").string(), AtlasPreview(proxy, atlas), PixelStorage::kUint8);
  ProxyFile proxy_file;
  proxy_file.mesh = "reconstruct/proxy.obj";
  proxy_file.atlas_resolution_px = options.atlas.resolution_px;
  const Eigen::AlignedBox3f bounds = proxy.Bounds();
  proxy_file.object_centre_m = bounds.center().cast<double>();
  for (const Eigen::Vector3f& p : proxy.positions) {
    proxy_file.object_radius_m = std::max(proxy_file.object_radius_m, (p.cast<double>() - proxy_file.object_centre_m).norm());
  }

  // 2. Trimaps and mattes, in parallel over frames.
  render::Scene scene;
  scene.AddObject(proxy, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();
  std::vector<const CalibratedFrame*> matte_frames = frames;
  if (options.max_matte_frames > 0 && static_cast<int>(frames.size()) > options.max_matte_frames) {
    matte_frames.clear();
    for (int i = 0; i < options.max_matte_frames; ++i) {
      matte_frames.push_back(frames[static_cast<size_t>(i) * frames.size() / options.max_matte_frames]);
    }
  }
  fs::create_directories(root / "mattes");
  fs::create_directories(root / "trimaps");
  std::vector<nlohmann::json> frame_reports(matte_frames.size());
  std::vector<bool> matted(matte_frames.size(), false);
  {
    auto timer = record.Time("mattes");
    std::unique_ptr<tbb::global_control> threads;
    if (options.matting.threads > 0) {
      threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      options.matting.threads);
    }
    Progress progress("mattes", static_cast<int64_t>(matte_frames.size()));
    tbb::parallel_for(size_t(0), matte_frames.size(), [&](size_t i) {
      const CalibratedFrame& frame = *matte_frames[i];
      const Camera camera = cameras.ViewCamera(frame);
      const cv::Mat silhouette = ProjectSilhouette(scene, camera);
      nlohmann::json& fr = frame_reports[i];
      fr["view_frame"] = frame.name;
      if (cv::countNonZero(silhouette) == 0) {
        spdlog::warn("{}: the proxy is not visible; no matte", frame.name);
        fr["skipped"] = "proxy not visible";
        progress.Advance();
        return;
      }
      const double depth = (camera.cam_from_world() * proxy_file.object_centre_m).z();
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
      matted[i] = true;
      progress.Advance();
    });
  }
  for (size_t i = 0; i < matte_frames.size(); ++i) {
    if (!matted[i]) {
      ++summary.skipped_frames;
      continue;
    }
    const std::string stem = FileStem(matte_frames[i]->name);
    proxy_file.mattes.push_back({matte_frames[i]->name, "reconstruct/mattes/" + stem + ".png",
                                 "reconstruct/trimaps/" + stem + ".png"});
  }
  RELIT_REQUIRE(!proxy_file.mattes.empty(), "reconstruct: the proxy is not visible in any phone V frame; "
                "is the mesh in the board frame (metres, +Z up)?");
  WriteProxyFile((root / "proxy.json").string(), proxy_file);

  report["cleanup"] = cleanup_report.ToJson();
  report["mesh"] = mesh_stats.ToJson();
  report["atlas"] = atlas_stats.ToJson();
  report["crop"] = {{"centre_xy_m", {crop.centre_xy.x(), crop.centre_xy.y()}}, {"radius_m", crop.radius_m}};
  report["frames"] = frame_reports;
  WriteJsonFile((root / "reconstruct_report.json").string(), kReportKind, kReportVersion, report);

  summary.faces = static_cast<int>(proxy.triangles.size());
  summary.charts = atlas.chart_count;
  summary.atlas_utilisation = atlas_stats.utilisation;
  summary.mattes = static_cast<int>(proxy_file.mattes.size());
  summary.seconds = SecondsSince(start);
  record.Set("faces", summary.faces);
  record.Set("charts", summary.charts);
  record.Set("atlas_utilisation", summary.atlas_utilisation);
  record.Set("mattes", summary.mattes);
  record.Set("skipped_frames", summary.skipped_frames);
  record.Write((root / "run.json").string());
  spdlog::info("reconstruct: {} faces, {} charts ({:.1f}% of the atlas), {} mattes in {:.1f} s", summary.faces,
               summary.charts, 100 * summary.atlas_utilisation, summary.mattes, summary.seconds);
  InitLogging("", level);  // close the log file before the folder moves
  out.Commit();
  summary.out_dir = out.target().string();
  return summary;
}

int RunReconstruct(int argc, char** argv) {
  CLI::App app{"relit-reconstruct: proxy mesh (cleanup, UV atlas), trimaps and closed-form alpha mattes. "
               "Reads W/calib/cameras.json, writes W/reconstruct. See docs/reconstruct.md."};
  std::string workspace, config, mesh, log_level;
  app.add_option("--workspace", workspace, "workspace folder W (reads W/calib, writes W/reconstruct)");
  app.add_option("--config", config, "YAML file with reconstruct options (unknown keys are errors)")
      ->check(CLI::ExistingFile);
  app.add_option("--mesh", mesh, "user-supplied proxy mesh (OBJ/PLY, board frame, metres); sets proxy.method: mesh")
      ->check(CLI::ExistingFile);
  std::string method;
  app.add_option("--proxy-method", method, "dense (default) | sparse | mesh (see docs/reconstruct.md)");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  bool force = false;
  app.add_flag("--force", force, "replace a W/reconstruct folder that relit-reconstruct did not write");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  ReconstructOptions options;
  if (!config.empty()) {
    OptionsReader reader = OptionsReader::FromFile(config);
    ReadOptions(reader, &options);
  }
  if (!workspace.empty()) options.workspace = workspace;
  if (!mesh.empty()) {
    options.mesh = mesh;
    options.proxy.method = "mesh";
  }
  if (!method.empty()) options.proxy.method = method;
  options.force = force;
  if (!log_level.empty()) options.log_level = log_level;
  SetVerbosity(ParseLogLevel(options.log_level));
  CheckOptions(options);
  RunReconstructImpl(options);
  return 0;
}

}  // namespace relit::reconstruct
