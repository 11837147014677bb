// relit-bench-reconstruct: the reconstruct stage's outputs in a workspace
// against the synthetic capture's ground truth (relit-synth's truth.json).
//  1. Proxy: symmetric mean Chamfer distance to the GT object mesh (mm and %
//     of the GT bounding-box diagonal), board triangles, components,
//     manifold, watertight.
//  2. Mattes on the workspace's own trimaps and undistorted frames, side by
//     side: the binary projected proxy silhouette, relit's closed-form matte
//     (as written by the stage; solved again for its time) and OpenCV
//     contrib's information-flow matting (cv::alphamat::infoFlow, Aksoy et
//     al. 2017): MSE, SAD and seconds per megapixel against GT alpha. The GT
//     alpha (truth/view_alpha, rendered through the true lens) is resampled
//     with the workspace's own calibrated undistortion, exactly like the
//     frames the mattes were computed on. Without GT alpha the mattes are
//     skipped (with a note).
//  3. --breakdown: the Chamfer distance after each step of the dense proxy
//     path; --write-truth-cameras: a copy of the workspace with true cameras
//     (reconstruct_breakdown.h).
//  4. --offset-sweep: the same matting with the GT mesh, moved by known
//     offsets along its normals, as the proxy (how the matte's gain over the
//     binary silhouette depends on the proxy's error).
// Reads only; results and how to reproduce them: docs/benchmarks.md,
// section "Reconstruct".
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>  // before alphamat.hpp, which does not include it
#include <opencv2/alphamat.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/bench_util.h"
#include "bench/reconstruct_breakdown.h"
#include "calib/truth_accuracy.h"
#include "calib/undistort.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/main_wrapper.h"
#include "core/progress.h"
#include "core/render/mesh.h"
#include "core/render/scene.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "reconstruct/closed_form_matting.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/trimap.h"

namespace relit::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct BenchOptions {
  std::string workspace;       // W with calib/ and reconstruct/ (read only)
  std::string synth;           // the relit-synth output W/capture was made from
  int max_frames = 12;         // matte frames compared (evenly spaced; 0 = all)
  int chamfer_samples = 50000;
  double board_band_m = 0.003; // "on the board": all three vertices below this height
  double footprint_m = 0.01;   // ...and farther than this (XY) from the object's base
  bool infoflow = true;
  bool breakdown = false;      // Chamfer after each proxy step (reconstruct_breakdown.h)
  std::string truth_cameras;   // write a ground-truth-camera copy of the workspace here and stop
  std::string error_maps;      // write a per-frame panel of the matte errors here
  std::vector<double> offset_sweep_mm;  // GT mesh offsets (mm along its normals) used as proxies
  int sweep_band_px = 0;       // the sweep's unknown half width; 0 = each frame's band from the stage
  std::string json_out;
};

render::TriangleMesh Merge(const std::vector<render::TriangleMesh>& meshes) {
  render::TriangleMesh out;
  for (const render::TriangleMesh& m : meshes) {
    const int base = static_cast<int>(out.positions.size());
    out.positions.insert(out.positions.end(), m.positions.begin(), m.positions.end());
    for (const Eigen::Vector3i& t : m.triangles) out.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  return out;
}

render::TriangleMesh GtMesh(const BenchOptions& o, const json& truth) {
  std::vector<render::TriangleMesh> objects;
  for (const json& object : truth.at("objects")) {
    objects.push_back(render::LoadMesh((fs::path(o.synth) / object.at("mesh").get<std::string>()).string()));
  }
  return Merge(objects);
}

json ProxyAccuracy(const BenchOptions& o, const json& truth, const render::TriangleMesh& proxy) {
  const render::TriangleMesh gt = GtMesh(o, truth);
  const double diagonal = gt.Bounds().diagonal().norm();
  const auto start = std::chrono::steady_clock::now();
  const double chamfer = reconstruct::SymmetricChamferDistance(proxy, gt, o.chamfer_samples);
  const double chamfer_s = SecondsSince(start);

  // Board triangles: below the board plane, or lying on it away from the
  // object's base (GT vertices within 1 cm of the board).
  std::vector<Eigen::Vector2f> footprint;
  for (const Eigen::Vector3f& p : gt.positions) {
    if (p.z() < 0.01f) footprint.push_back(p.head<2>());
  }
  int below = 0, on_board = 0;
  for (const Eigen::Vector3i& t : proxy.triangles) {
    const Eigen::Vector3f& a = proxy.positions[t[0]];
    const Eigen::Vector3f& b = proxy.positions[t[1]];
    const Eigen::Vector3f& c = proxy.positions[t[2]];
    if (std::min({a.z(), b.z(), c.z()}) <= 0) {
      ++below;
      continue;
    }
    if (std::max({a.z(), b.z(), c.z()}) >= o.board_band_m) continue;
    const Eigen::Vector2f centroid = ((a + b + c) / 3).head<2>();
    float nearest = 1e9f;
    for (const Eigen::Vector2f& q : footprint) nearest = std::min(nearest, (centroid - q).norm());
    if (nearest > o.footprint_m) ++on_board;
  }
  const reconstruct::MeshStats stats = reconstruct::AnalyseMesh(proxy);
  return {{"gt_bbox_diagonal_m", diagonal},
          {"chamfer_mm", chamfer * 1e3},
          {"chamfer_percent_of_diagonal", 100 * chamfer / diagonal},
          {"chamfer_samples", o.chamfer_samples},
          {"chamfer_seconds", chamfer_s},
          {"faces", stats.faces},
          {"faces_below_board", below},
          {"faces_on_board_outside_footprint", on_board},
          {"components", stats.components},
          {"manifold", stats.manifold()},
          {"watertight", stats.closed()},
          {"boundary_edges", stats.boundary_edges},
          {"self_intersects", stats.self_intersects},
          {"volume_m3", stats.volume_m3}};
}

// Errors of one method summed over frames. The unknown band is where the
// methods differ; the known regions carry the trimap's own errors (a proxy
// silhouette off by more than the band), which no matting can undo.
struct MethodErrors {
  double mse = 0, mse_unknown = 0, sse_known_fraction = 0, sad = 0, seconds = 0;
  int frames = 0;
  void Add(const cv::Mat& alpha, const cv::Mat& truth, const cv::Mat& unknown, double s) {
    cv::Mat d;
    cv::subtract(alpha, truth, d, cv::noArray(), CV_64F);
    const cv::Mat d2 = d.mul(d);
    mse += cv::mean(d2)[0];
    mse_unknown += cv::mean(d2, unknown)[0];
    const double sse = cv::sum(d2)[0];
    cv::Mat known;
    cv::bitwise_not(unknown, known);
    known.convertTo(known, CV_64F, 1.0 / 255);
    sse_known_fraction += sse > 0 ? cv::sum(d2.mul(known))[0] / sse : 0;
    sad += cv::norm(d, cv::NORM_L1);
    seconds += s;
    ++frames;
  }
  json ToJson(double megapixels) const {
    const double n = std::max(1, frames);
    return {{"mse", mse / n}, {"mse_unknown_band", mse_unknown / n},
            {"squared_error_fraction_in_known_regions", sse_known_fraction / n}, {"sad", sad / n},
            {"seconds_per_frame", seconds / n}, {"seconds_per_megapixel", seconds / n / megapixels}};
  }
};

reconstruct::MattingOptions StageMattingOptions(const fs::path& workspace) {
  reconstruct::MattingOptions m;
  const fs::path run = workspace / "reconstruct" / "run.json";
  if (!fs::exists(run)) return m;
  const json options = ReadJsonFile(run.string(), "run", 1).value("options", json::object());
  const json matting = options.value("matting", json::object());
  m.window_radius_px = matting.value("window_radius_px", m.window_radius_px);
  m.epsilon = matting.value("epsilon", m.epsilon);
  m.prior_weight = matting.value("prior_weight", m.prior_weight);
  m.multiscale_min_megapixels = matting.value("multiscale_min_megapixels", m.multiscale_min_megapixels);
  return m;
}

// One row per frame: image, trimap, GT alpha, binary silhouette, relit's matte,
// then the two signed errors (red: too opaque, blue: too transparent).
void WriteErrorPanel(const std::string& folder, const std::string& frame, const cv::Mat& colour,
                     const cv::Mat& trimap, const cv::Mat& gt, const cv::Mat& binary, const cv::Mat& relit) {
  auto gray = [](const cv::Mat& a) {
    cv::Mat out;
    a.convertTo(out, CV_8U, a.depth() == CV_8U ? 1.0 : 255.0);
    cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
    return out;
  };
  auto signed_error = [&](const cv::Mat& alpha) {
    cv::Mat d = alpha - gt, over, under;
    cv::max(d, 0.0, over);
    cv::max(-d, 0.0, under);
    cv::Mat zero = cv::Mat::zeros(d.size(), CV_32F), bgr;
    cv::merge(std::vector<cv::Mat>{under, zero, over}, bgr);
    bgr.convertTo(bgr, CV_8UC3, 255.0);
    return bgr;
  };
  cv::Mat image;
  cv::cvtColor(colour, image, cv::COLOR_RGB2BGR);
  image.convertTo(image, CV_8UC3, 255.0);
  cv::Mat row;
  cv::hconcat(std::vector<cv::Mat>{image, gray(trimap), gray(gt), gray(binary), gray(relit), signed_error(binary),
                                   signed_error(relit)},
              row);
  fs::create_directories(folder);
  std::string name = frame;
  std::replace(name.begin(), name.end(), '/', '_');
  cv::imwrite((fs::path(folder) / (name + ".png")).string(), row);
}

// What the matte comparisons need of one matted frame: its camera, its
// undistorted colour image, the stage's trimap, band and matte, and the GT
// alpha resampled exactly like the frame.
struct MatteFrame {
  std::string name;
  Camera camera;
  cv::Mat colour, trimap, unknown, stored, gt;
  std::string image_8bit;  // the undistorted frame's file
  int band_px = 0;
};

class MatteFrames {
 public:
  // `report`: the workspace's reconstruct_report.json (each frame's band).
  MatteFrames(const BenchOptions& o, const json& truth, const ProxyFile& proxy, const json& report)
      : o_(o), truth_(truth), ws_(o.workspace),
        cameras_(ReadCamerasFile((ws_ / "calib" / "cameras.json").string())),
        undistorter_(cameras_.devices.at("view"), cameras_.undistorted_view),
        matting_(StageMattingOptions(ws_)), mattes_(proxy.mattes.size()) {
    for (const CaptureFrame& f : ReadCaptureFile(CaptureFilePath(ws_.string())).view) {
      source_frame_[f.index] = f.source_frame;
    }
    for (const json& f : report.value("frames", json::array())) {
      if (f.contains("band_px")) band_px_[f.at("view_frame")] = f.at("band_px");
    }
    const size_t n = proxy.mattes.size();
    const size_t wanted = o.max_frames > 0 ? std::min(n, static_cast<size_t>(o.max_frames)) : n;
    for (size_t i = 0; i < wanted; ++i) selected_.push_back(&proxy.mattes[i * n / wanted]);
    RELIT_REQUIRE(!selected_.empty(), ws_.string(), "/reconstruct/proxy.json lists no mattes");
  }
  const std::vector<const ViewMatte*>& selected() const { return selected_; }
  size_t mattes() const { return mattes_; }  // in the workspace, selected or not
  // The options the stage matted with (its run.json).
  const reconstruct::MattingOptions& matting() const { return matting_; }
  double megapixels() const { return cameras_.undistorted_view.width * cameras_.undistorted_view.height / 1e6; }

  MatteFrame Load(const ViewMatte& vm) const {
    MatteFrame m;
    m.name = vm.view_frame;
    const CalibratedFrame* frame = cameras_.Find(vm.view_frame);
    RELIT_REQUIRE(frame, "matte of ", vm.view_frame, " has no frame in cameras.json");
    m.camera = cameras_.ViewCamera(*frame);
    const int index = std::stoi(vm.view_frame.substr(vm.view_frame.find('/') + 1));
    const json& truth_frame = truth_.at("videos").at("view").at("frames").at(source_frame_.at(index));
    const Intrinsics& lens = cameras_.devices.at("view");
    m.gt = undistorter_.Remap(calib::DisplayedTruthAlpha(
        (fs::path(o_.synth) / truth_frame.at("alpha").get<std::string>()).string(),
        calib::TruthDisplayRotation(truth_, "view"), lens.width, lens.height));
    cv::min(m.gt, 1.0, m.gt);  // the resampling kernel overshoots at the rim
    ReadImage((ws_ / vm.trimap).string()).ToMat().convertTo(m.trimap, CV_8U, 255.0);
    if (m.trimap.channels() > 1) cv::extractChannel(m.trimap, m.trimap, 0);
    m.unknown = m.trimap == reconstruct::kTrimapUnknown;
    m.stored = ReadImage((ws_ / vm.matte).string()).ToMat();
    if (m.stored.channels() > 1) cv::extractChannel(m.stored, m.stored, 0);
    m.colour = ReadImage((ws_ / frame->image_8bit).string()).SelectChannels(std::vector<int>{0, 1, 2}).ToMat();
    const auto band = band_px_.find(vm.view_frame);
    m.band_px = band != band_px_.end() ? band->second : 0;
    m.image_8bit = (ws_ / frame->image_8bit).string();
    return m;
  }

 private:
  const BenchOptions& o_;
  const json& truth_;
  fs::path ws_;
  CamerasFile cameras_;
  calib::FrameUndistorter undistorter_;
  reconstruct::MattingOptions matting_;
  size_t mattes_;
  std::map<int, int> source_frame_;  // capture index -> rendered video frame
  std::map<std::string, int> band_px_;
  std::vector<const ViewMatte*> selected_;
};

json MatteComparison(const BenchOptions& o, const MatteFrames& matte_frames, const render::TriangleMesh& proxy_mesh) {
  const reconstruct::MattingOptions& matting = matte_frames.matting();
  render::Scene scene;
  scene.AddObject(proxy_mesh, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();
  MethodErrors binary, relit, infoflow;
  const double megapixels = matte_frames.megapixels();
  json per_frame = json::array();
  for (const ViewMatte* vm : matte_frames.selected()) {
    const MatteFrame m = matte_frames.Load(*vm);
    auto start = std::chrono::steady_clock::now();
    const cv::Mat silhouette = reconstruct::ProjectSilhouette(scene, m.camera);
    cv::Mat binary_alpha;
    silhouette.convertTo(binary_alpha, CV_32F, 1.0 / 255.0);
    binary.Add(binary_alpha, m.gt, m.unknown, SecondsSince(start));

    // relit's matte as the stage wrote it; the solve is repeated for its time.
    reconstruct::MatteStats stats;
    start = std::chrono::steady_clock::now();
    const cv::Mat resolved = reconstruct::SolveClosedFormMatte(m.colour, m.trimap, binary_alpha, matting, &stats);
    const double relit_s = SecondsSince(start);
    relit.Add(m.stored, m.gt, m.unknown, relit_s);
    const double resolve_difference = cv::norm(resolved, m.stored, cv::NORM_INF);

    json row = {{"frame", m.name}, {"unknown_px", cv::countNonZero(m.unknown)},
                {"relit_resolve_max_difference", resolve_difference}};
    if (o.infoflow) {
      const cv::Mat bgr = cv::imread(m.image_8bit, cv::IMREAD_COLOR);
      cv::Mat result, alpha;
      start = std::chrono::steady_clock::now();
      cv::alphamat::infoFlow(bgr, m.trimap, result);
      const double seconds = SecondsSince(start);
      result.convertTo(alpha, CV_32F, result.depth() == CV_8U ? 1.0 / 255.0 : 1.0);
      cv::min(cv::max(alpha, 0.0), 1.0, alpha);
      infoflow.Add(alpha, m.gt, m.unknown, seconds);
      row["infoflow_seconds"] = seconds;
    }
    row["relit_seconds"] = relit_s;
    per_frame.push_back(row);
    if (!o.error_maps.empty()) WriteErrorPanel(o.error_maps, m.name, m.colour, m.trimap, m.gt, binary_alpha, m.stored);
    std::fprintf(stderr, "  %s: %d unknown px, relit %.2f s%s\n", m.name.c_str(), row["unknown_px"].get<int>(),
                 relit_s,
                 o.infoflow ? (", infoFlow " + std::to_string(row["infoflow_seconds"].get<double>()) + " s").c_str()
                            : "");
  }
  json out = {{"frames", matte_frames.selected().size()},
              {"of_mattes", matte_frames.mattes()},
              {"image_megapixels", megapixels},
              {"binary_silhouette", binary.ToJson(megapixels)},
              {"relit_closed_form", relit.ToJson(megapixels)},
              {"per_frame", per_frame}};
  if (o.infoflow) out["opencv_infoflow"] = infoflow.ToJson(megapixels);
  return out;
}

// How the matte's gain over the binary silhouette depends on the proxy's
// error: the GT mesh moved by d mm along its vertex normals (outward > 0,
// never below the board) stands in for a proxy of known, uniform error; each
// frame gets the stage's own band width, matting options and prior (that
// silhouette), on the same images and GT alpha.
json OffsetSweep(const BenchOptions& o, const json& truth, const MatteFrames& matte_frames) {
  const reconstruct::MattingOptions& matting = matte_frames.matting();
  render::TriangleMesh gt_mesh = reconstruct::WeldEqualPositions(GtMesh(o, truth));
  gt_mesh.ComputeVertexNormals();  // every offset moves along the GT's own normals
  std::vector<std::unique_ptr<render::Scene>> scenes;
  for (double offset_mm : o.offset_sweep_mm) {
    render::TriangleMesh moved = gt_mesh;
    for (size_t v = 0; v < moved.positions.size(); ++v) {
      moved.positions[v] += static_cast<float>(1e-3 * offset_mm) * gt_mesh.normals[v];
      moved.positions[v].z() = std::max(moved.positions[v].z(), 0.0f);
    }
    scenes.push_back(std::make_unique<render::Scene>());
    scenes.back()->AddObject(moved, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
    scenes.back()->Commit();
  }
  std::vector<MethodErrors> binary(scenes.size()), matte(scenes.size());
  Progress progress("offset sweep", static_cast<int64_t>(matte_frames.selected().size()));
  for (const ViewMatte* vm : matte_frames.selected()) {
    const MatteFrame m = matte_frames.Load(*vm);
    RELIT_REQUIRE(o.sweep_band_px > 0 || m.band_px > 0, o.workspace,
                  "/reconstruct/reconstruct_report.json gives no band_px for ", m.name, "; pass --sweep-band-px");
    for (size_t k = 0; k < scenes.size(); ++k) {
      const cv::Mat silhouette = reconstruct::ProjectSilhouette(*scenes[k], m.camera);
      cv::Mat prior;
      silhouette.convertTo(prior, CV_32F, 1.0 / 255.0);
      binary[k].Add(prior, m.gt, m.unknown, 0);
      reconstruct::MatteStats stats;
      const cv::Mat trimap = reconstruct::MakeTrimap(silhouette, o.sweep_band_px > 0 ? o.sweep_band_px : m.band_px);
      matte[k].Add(reconstruct::SolveClosedFormMatte(m.colour, trimap, prior, matting, &stats), m.gt, m.unknown, 0);
    }
    progress.Advance();
  }
  json rows = json::array();
  for (size_t k = 0; k < scenes.size(); ++k) {
    const double b = binary[k].mse / binary[k].frames, r = matte[k].mse / matte[k].frames;
    rows.push_back({{"offset_mm", o.offset_sweep_mm[k]}, {"binary_mse", b}, {"matte_mse", r}, {"ratio", b / r}});
  }
  return {{"frames", matte_frames.selected().size()}, {"band_px", o.sweep_band_px}, {"rows", rows}};
}

// The first GT alpha file truth.json names that is missing, or "" when all
// exist. A synthetic output without them (e.g. a copy without
// truth/view_alpha) skips the matte comparison.
std::string MissingAlpha(const BenchOptions& o, const json& truth) {
  for (const json& f : truth.at("videos").at("view").at("frames")) {
    const fs::path alpha = fs::path(o.synth) / f.value("alpha", std::string());
    if (!f.contains("alpha") || !fs::exists(alpha)) return alpha.string();
  }
  return "";
}

void PrintTable(const json& proxy, const json& mattes) {
  std::printf("\nproxy vs GT mesh: Chamfer %.2f mm = %.2f%% of the GT bbox diagonal (%.1f mm); %d faces, "
              "%d below the board, %d on the board outside the footprint; %d component(s), manifold %s, "
              "watertight %s, self-intersecting %s\n",
              proxy["chamfer_mm"].get<double>(), proxy["chamfer_percent_of_diagonal"].get<double>(),
              1e3 * proxy["gt_bbox_diagonal_m"].get<double>(), proxy["faces"].get<int>(),
              proxy["faces_below_board"].get<int>(), proxy["faces_on_board_outside_footprint"].get<int>(),
              proxy["components"].get<int>(), proxy["manifold"].get<bool>() ? "yes" : "no",
              proxy["watertight"].get<bool>() ? "yes" : "no", proxy["self_intersects"].get<bool>() ? "yes" : "no");
  if (mattes.contains("skipped")) {
    std::printf("\nmattes: skipped (%s)\n", mattes["skipped"].get<std::string>().c_str());
    return;
  }
  const json& relit = mattes["relit_closed_form"];
  std::printf("\nmattes vs GT alpha (%d of %d frames, %.3f MP, same trimaps; means per frame)\n",
              mattes["frames"].get<int>(), mattes["of_mattes"].get<int>(), mattes["image_megapixels"].get<double>());
  std::printf("%-28s %11s %9s %13s %8s %9s %9s %11s\n", "method", "MSE", "MSE/relit", "MSE unknown", "SE known",
              "SAD", "SAD/relit", "s/MP");
  for (const char* key : {"binary_silhouette", "relit_closed_form", "opencv_infoflow"}) {
    if (!mattes.contains(key)) continue;
    const json& m = mattes[key];
    std::printf("%-28s %11.6f %9.2f %13.5f %7.0f%% %9.1f %9.2f %11.3f\n", key, m["mse"].get<double>(),
                m["mse"].get<double>() / relit["mse"].get<double>(), m["mse_unknown_band"].get<double>(),
                100 * m["squared_error_fraction_in_known_regions"].get<double>(),
                m["sad"].get<double>(), m["sad"].get<double>() / relit["sad"].get<double>(),
                m["seconds_per_megapixel"].get<double>());
  }
}

void PrintOffsetSweep(const json& sweep) {
  const int band_px = sweep["band_px"].get<int>();
  std::printf("\nGT mesh offset as the proxy (%d frames, %s, the stage's matting options)\n",
              sweep["frames"].get<int>(),
              band_px > 0 ? ("band half width " + std::to_string(band_px) + " px").c_str() : "the stage's bands");
  std::printf("%10s %12s %12s %8s\n", "offset mm", "binary MSE", "matte MSE", "ratio");
  for (const json& row : sweep["rows"]) {
    std::printf("%10.1f %12.6f %12.6f %8.2f\n", row["offset_mm"].get<double>(), row["binary_mse"].get<double>(),
                row["matte_mse"].get<double>(), row["ratio"].get<double>());
  }
}

int RunReconstructBench(int argc, char** argv) {
  CLI::App app{"relit-bench-reconstruct: proxy accuracy and mattes (binary silhouette, relit closed-form, "
               "OpenCV alphamat::infoFlow) of a workspace against its synthetic ground truth. Reads only."};
  BenchOptions o;
  app.add_option("--workspace", o.workspace, "workspace W with calib/ and reconstruct/")->required();
  app.add_option("--synth", o.synth, "relit-synth output folder (truth.json, truth/) W/capture was made from")
      ->required();
  app.add_option("--max-frames", o.max_frames, "matte frames compared, evenly spaced (0 = all)");
  app.add_option("--chamfer-samples", o.chamfer_samples, "surface samples per mesh for the Chamfer distance");
  app.add_option("--board-band-m", o.board_band_m, "a face lies on the board when all vertices are below this");
  app.add_flag("!--no-infoflow", o.infoflow, "skip OpenCV's infoFlow");
  app.add_flag("--breakdown", o.breakdown,
               "also measure the Chamfer distance after each proxy step (fused points, raw Poisson, cleanup, "
               "remeshing, small-handle cut; dense proxies only)");
  app.add_option("--write-truth-cameras", o.truth_cameras,
                 "write a copy of the workspace with the true lens and poses of the phone V frames to this folder "
                 "(calib/ only, capture/ linked) and stop; run relit-reconstruct on it");
  app.add_option("--error-maps", o.error_maps,
                 "write a panel per compared frame to this folder: image, trimap, GT alpha, binary silhouette, "
                 "relit matte and both signed errors (red: too opaque, blue: too transparent)");
  app.add_option("--offset-sweep", o.offset_sweep_mm,
                 "also matte with the GT mesh moved by each of these offsets (mm along its normals, e.g. "
                 "-2,0,2,5) as the proxy: binary and matte MSE per offset (the stage's band and options)")
      ->delimiter(',');
  app.add_option("--sweep-band-px", o.sweep_band_px,
                 "the offset sweep's unknown band half width in pixels instead of each frame's band from the stage "
                 "(how much a matte can add to an exact silhouette as the band narrows)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--json", o.json_out, "also write the results to this JSON file");
  CLI11_PARSE(app, argc, argv);
  RELIT_REQUIRE(o.sweep_band_px == 0 || !o.offset_sweep_mm.empty(),
                "--sweep-band-px only sets the offset sweep's band: add --offset-sweep (e.g. --offset-sweep=0,2)");
  const fs::path ws(o.workspace);
  if (!o.truth_cameras.empty()) {
    WriteTruthCameraWorkspace(o.workspace, o.synth, o.truth_cameras);
    return 0;
  }
  const ProxyFile proxy = ReadProxyFile((ws / "reconstruct" / "proxy.json").string());
  const json truth = ReadJsonFile((fs::path(o.synth) / "truth.json").string(), "synth_truth", 1);
  const render::TriangleMesh mesh = render::LoadMesh((ws / proxy.mesh).string());
  const json report = ReadJsonFile((ws / "reconstruct" / "reconstruct_report.json").string(), "reconstruct_report", 1);
  std::fprintf(stderr, "relit-bench-reconstruct: %s (%s proxy from %s frames), load %s\n", o.workspace.c_str(),
               report["proxy"].value("method", std::string("?")).c_str(),
               report["proxy"].contains("input_frames")
                   ? report["proxy"]["input_frames"].value("device", std::string("?")).c_str() : "?",
               LoadAverage().c_str());
  json results = {{"workspace", fs::absolute(ws).string()},
                  {"synth", fs::absolute(o.synth).string()},
                  {"date", Today()},
                  {"load_average", LoadAverage()},
                  {"proxy_source", report["proxy"]}};
  results["proxy_source"].erase("frames");
  results["proxy"] = ProxyAccuracy(o, truth, mesh);
  if (o.breakdown) results["proxy_breakdown"] = ProxyBreakdown(o.workspace, GtMesh(o, truth), o.chamfer_samples);
  const std::string missing_alpha = MissingAlpha(o, truth);
  RELIT_REQUIRE(o.offset_sweep_mm.empty() || missing_alpha.empty(), "--offset-sweep needs GT alpha: ", missing_alpha,
                " is missing");
  if (missing_alpha.empty()) {
    const MatteFrames matte_frames(o, truth, proxy, report);
    results["mattes"] = MatteComparison(o, matte_frames, mesh);
    if (!o.offset_sweep_mm.empty()) results["offset_sweep"] = OffsetSweep(o, truth, matte_frames);
  } else {
    results["mattes"] = {{"skipped", "no GT alpha " + missing_alpha +
                                         ": --synth must be the relit-synth output with truth/view_alpha"}};
  }
  PrintTable(results["proxy"], results["mattes"]);
  if (results.contains("offset_sweep")) PrintOffsetSweep(results["offset_sweep"]);
  if (!o.json_out.empty()) WriteJsonFile(o.json_out, "bench_reconstruct", 1, results);
  return 0;
}

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::bench::RunReconstructBench); }
