#include "bench/reconstruct_breakdown.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "bench/bench_util.h"
#include "calib/undistort.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/run_record.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/point_surface.h"
#include "reconstruct/proxy_source.h"

namespace relit::bench {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

double Mean(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? 0 : sum / v.size();
}

double P90(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() * 9 / 10, v.end());
  return v[v.size() * 9 / 10];
}

// GT split by face orientation: the down-facing parts (belly, inner legs)
// are what orbiting cameras above the object rarely see.
struct GtParts {
  render::TriangleMesh down, rest;
};

GtParts SplitGt(const render::TriangleMesh& gt) {
  GtParts parts;
  parts.down.positions = parts.rest.positions = gt.positions;
  for (const Eigen::Vector3i& t : gt.triangles) {
    const Eigen::Vector3f n =
        (gt.positions[t[1]] - gt.positions[t[0]]).cross(gt.positions[t[2]] - gt.positions[t[0]]).normalized();
    (n.z() < -0.25f ? parts.down : parts.rest).triangles.push_back(t);
  }
  return parts;
}

double Area(const render::TriangleMesh& m) {
  double a = 0;
  for (const Eigen::Vector3i& t : m.triangles) {
    a += 0.5 * (m.positions[t[1]] - m.positions[t[0]]).cross(m.positions[t[2]] - m.positions[t[0]]).norm();
  }
  return a;
}

struct Measure {
  const render::TriangleMesh& gt;
  GtParts parts;
  double diagonal;
  int samples;
  const std::vector<Eigen::Vector3d>* fused;
  double support_m;

  // `to_gt`: distances from the candidate's samples to the GT surface;
  // `from_gt(points)`: distances from GT samples to the candidate.
  template <typename FromGt>
  json Row(const std::string& step, const std::vector<double>& to_gt, FromGt from_gt) const {
    const std::vector<double> completeness = from_gt(reconstruct::SampleSurface(gt, samples, 2));
    const double down_area = Area(parts.down), rest_area = Area(parts.rest);
    const int down_samples = std::max(1, static_cast<int>(samples * down_area / (down_area + rest_area)));
    const double accuracy = Mean(to_gt), complete = Mean(completeness);
    const double chamfer = 0.5 * (accuracy + complete);
    json row = {{"step", step},
                {"accuracy_mm", 1e3 * accuracy},
                {"accuracy_p90_mm", 1e3 * P90(to_gt)},
                {"completeness_mm", 1e3 * complete},
                {"completeness_p90_mm", 1e3 * P90(completeness)},
                {"completeness_down_facing_mm", 1e3 * Mean(from_gt(reconstruct::SampleSurface(parts.down, down_samples, 3)))},
                {"completeness_rest_mm", 1e3 * Mean(from_gt(reconstruct::SampleSurface(parts.rest, samples - down_samples, 4)))},
                {"down_facing_area_fraction", down_area / (down_area + rest_area)},
                {"chamfer_mm", 1e3 * chamfer},
                {"chamfer_percent_of_diagonal", 100 * chamfer / diagonal}};
    std::fprintf(stderr, "  %-34s Chamfer %5.2f mm = %5.2f%%  (accuracy %.2f mm p90 %.2f, completeness %.2f mm p90 %.2f; down-facing GT %.2f mm, rest %.2f mm)\n",
                 step.c_str(), row["chamfer_mm"].get<double>(), row["chamfer_percent_of_diagonal"].get<double>(),
                 row["accuracy_mm"].get<double>(), row["accuracy_p90_mm"].get<double>(),
                 row["completeness_mm"].get<double>(), row["completeness_p90_mm"].get<double>(),
                 row["completeness_down_facing_mm"].get<double>(), row["completeness_rest_mm"].get<double>());
    return row;
  }

  // Also splits the accuracy by support: mesh samples within support_m of
  // a fused point (measured surface) and the rest (Poisson extrapolation,
  // hole fills).
  json MeshRow(const std::string& step, const render::TriangleMesh& mesh) const {
    const std::vector<Eigen::Vector3d> at = reconstruct::SampleSurface(mesh, samples, 1);
    const std::vector<double> to_gt = reconstruct::DistancesToSurface(at, gt);
    json row = Row(step, to_gt,
                   [&](const std::vector<Eigen::Vector3d>& q) { return reconstruct::DistancesToSurface(q, mesh); });
    const std::vector<double> to_points = reconstruct::DistancesToPoints(at, *fused);
    std::vector<double> supported, unsupported;
    for (std::size_t i = 0; i < at.size(); ++i) (to_points[i] <= support_m ? supported : unsupported).push_back(to_gt[i]);
    row["accuracy_supported_mm"] = 1e3 * Mean(supported);
    row["accuracy_unsupported_mm"] = 1e3 * Mean(unsupported);
    row["unsupported_area_fraction"] = static_cast<double>(unsupported.size()) / at.size();
    std::fprintf(stderr, "  %-34s   accuracy where a fused point is within %.1f mm: %.2f mm; elsewhere (%.0f%% of the area): %.2f mm\n",
                 "", 1e3 * support_m, 1e3 * Mean(supported), 100.0 * unsupported.size() / at.size(), 1e3 * Mean(unsupported));
    const reconstruct::MeshStats stats = reconstruct::AnalyseMesh(mesh);
    row["faces"] = stats.faces;
    row["components"] = stats.components;
    row["closed"] = stats.closed();
    row["manifold"] = stats.manifold();
    row["self_intersects"] = stats.self_intersects;
    if (stats.closed() && stats.manifold()) {
      // Euler: V - E + F = 2 (C - g), E = 3F / 2 on a closed triangle mesh.
      row["genus"] = stats.components - (stats.vertices - stats.faces / 2) / 2;
    }
    return row;
  }
};

}  // namespace

json ProxyBreakdown(const std::string& workspace, const render::TriangleMesh& gt, int samples) {
  const fs::path ws(workspace);
  const fs::path points_dir = ws / "reconstruct" / "proxy_points";
  RELIT_REQUIRE(fs::exists(points_dir / "poisson.ply"), workspace,
                ": no reconstruct/proxy_points/poisson.ply (the breakdown needs a dense proxy run)");
  const json run = ReadJsonFile((ws / "reconstruct" / "run.json").string(), "run", 1);
  const json cleanup_json = run.at("options").value("cleanup", json::object());
  reconstruct::CleanupOptions cleanup;
  cleanup.crop_margin_m = cleanup_json.value("crop_margin_m", cleanup.crop_margin_m);
  cleanup.crop_radius_m = cleanup_json.value("crop_radius_m", cleanup.crop_radius_m);
  cleanup.crop_radius_scale = cleanup_json.value("crop_radius_scale", cleanup.crop_radius_scale);
  cleanup.min_component_fraction = cleanup_json.value("min_component_fraction", cleanup.min_component_fraction);
  cleanup.target_faces = cleanup_json.value("target_faces", cleanup.target_faces);
  cleanup.remesh_iterations = cleanup_json.value("remesh_iterations", cleanup.remesh_iterations);
  cleanup.fair_holes = cleanup_json.value("fair_holes", cleanup.fair_holes);
  cleanup.cut_off_fraction = cleanup_json.value("cut_off_fraction", cleanup.cut_off_fraction);
  const CamerasFile cameras = ReadCamerasFile((ws / "calib" / "cameras.json").string());
  std::string source;
  const reconstruct::CropRegion crop =
      reconstruct::CropFromCameras(cameras, reconstruct::GeometryFrames(cameras, &source), cleanup);

  const auto start = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> fused;
  for (const reconstruct::OrientedPoint& p : reconstruct::ReadOrientedPly((points_dir / "fused_points.ply").string())) {
    fused.push_back(p.position_m);
  }
  const json stage_report = ReadJsonFile((ws / "reconstruct" / "reconstruct_report.json").string(), "reconstruct_report", 1);
  // Support radius: 3x the fused point spacing (gaps in the points are holes).
  const double spacing = stage_report.at("proxy").value("point_spacing_m", 0.0015);
  Measure measure{gt, SplitGt(gt), gt.Bounds().diagonal().norm(), samples, &fused, 3 * spacing};
  json rows = json::array();
  std::vector<double> signed_distances;
  rows.push_back(measure.Row("(a) fused points", reconstruct::DistancesToSurface(fused, gt, &signed_distances),
                             [&](const std::vector<Eigen::Vector3d>& q) { return reconstruct::DistancesToPoints(q, fused); }));
  rows.back()["points"] = fused.size();
  // Bias: a systematic offset (e.g. stereo foreground fattening) vs noise.
  std::size_t outside = 0;
  for (double d : signed_distances) outside += d > 0 ? 1 : 0;
  std::vector<double> sorted = signed_distances;
  std::sort(sorted.begin(), sorted.end());
  rows.back()["signed_mean_mm"] = 1e3 * Mean(signed_distances);
  rows.back()["signed_median_mm"] = sorted.empty() ? 0.0 : 1e3 * sorted[sorted.size() / 2];
  rows.back()["outside_fraction"] = sorted.empty() ? 0.0 : static_cast<double>(outside) / sorted.size();
  std::fprintf(stderr, "  %-34s   signed distance to GT: mean %+.2f mm, median %+.2f mm, %.0f%% outside\n", "",
               rows.back()["signed_mean_mm"].get<double>(), rows.back()["signed_median_mm"].get<double>(),
               100 * rows.back()["outside_fraction"].get<double>());
  const render::TriangleMesh poisson = reconstruct::ReadPlySoup((points_dir / "poisson.ply").string());
  rows.push_back(measure.Row("(b) raw Poisson surface",
                             reconstruct::DistancesToSurface(reconstruct::SampleSurface(poisson, samples, 1), gt),
                             [&](const std::vector<Eigen::Vector3d>& q) { return reconstruct::DistancesToSurface(q, poisson); }));
  rows.back()["faces"] = poisson.triangles.size();

  reconstruct::CleanupReport report;
  reconstruct::CleanupOptions step = cleanup;
  step.remesh_iterations = 0;
  step.target_faces = 1 << 30;
  step.cut_small_handles = false;
  rows.push_back(measure.MeshRow("(c) cropped, repaired, holes filled", reconstruct::CleanupMesh(poisson, step, crop, &report)));
  step = cleanup;
  step.cut_small_handles = false;
  rows.push_back(measure.MeshRow("(d) + remeshed, decimated", reconstruct::CleanupMesh(poisson, step, crop, &report)));
  step.cut_small_handles = true;
  rows.push_back(measure.MeshRow("(e) + small handles cut", reconstruct::CleanupMesh(poisson, step, crop, &report)));
  rows.back()["handles_cut"] = report.handles_cut;
  const ProxyFile proxy = ReadProxyFile((ws / "reconstruct" / "proxy.json").string());
  rows.push_back(measure.MeshRow("workspace proxy", render::LoadMesh((ws / proxy.mesh).string())));
  return {{"steps", rows}, {"samples", samples}, {"seconds", SecondsSince(start)}};
}

void WriteTruthCameraWorkspace(const std::string& workspace, const std::string& synth, const std::string& out) {
  const fs::path ws(workspace), dst(out);
  RELIT_REQUIRE(!fs::exists(dst / "calib"), out, "/calib exists: pick a new folder");
  const json truth = ReadJsonFile((fs::path(synth) / "truth.json").string(), "synth_truth", 1);
  const CaptureFile capture = ReadCaptureFile(CaptureFilePath(ws.string()));
  CamerasFile cameras = ReadCamerasFile((ws / "calib" / "cameras.json").string());
  const Intrinsics lens = IntrinsicsFromJson(truth.at("phones").at("view").at("intrinsics"), "truth view lens");
  cameras.devices["view"] = lens;
  cameras.devices.erase("light");
  const calib::FrameUndistorter undistorter(lens, cameras.undistorted_view);
  std::vector<CalibratedFrame> frames;
  for (const CalibratedFrame& f : cameras.frames) {
    if (f.device != "view" || f.image_8bit.empty()) continue;
    const CaptureFrame* c = capture.Find(f.name);
    RELIT_REQUIRE(c != nullptr, "calib frame ", f.name, " is not in ", CaptureFilePath(ws.string()));
    const json& t = truth.at("videos").at("view").at("frames").at(c->source_frame);
    CalibratedFrame frame = f;
    frame.cam_from_world = Rigid3FromJson(t.at("cam_from_world"), f.name);
    frame.image_linear.clear();
    undistorter.RunSrgb((ws / c->image).string(), (dst / f.image_8bit).string());
    frames.push_back(frame);
  }
  cameras.frames = frames;
  fs::create_directories(dst / "calib");
  if (!fs::exists(dst / "capture")) fs::create_directory_symlink(fs::absolute(ws / "capture"), dst / "capture");
  WriteCamerasFile((dst / "calib" / "cameras.json").string(), cameras);
  std::fprintf(stderr, "wrote %s/calib/cameras.json: %zu phone V frames with true lens and poses\n", out.c_str(),
               frames.size());
}

}  // namespace relit::bench
