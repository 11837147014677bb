#include "bench/capture_scores.h"

#include <cmath>
#include <functional>
#include <filesystem>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "calib/truth_accuracy.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/render/mesh.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"

namespace relit::bench {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

render::TriangleMesh TruthObjects(const fs::path& capture, const json& truth) {
  render::TriangleMesh merged;
  RELIT_REQUIRE(truth.contains("objects") && !truth["objects"].empty(), (capture / "truth.json").string(),
                ": no \"objects\" (the foreground meshes the proxy is scored against)");
  for (const json& object : truth["objects"]) {
    const render::TriangleMesh mesh = render::LoadMesh((capture / object.at("mesh").get<std::string>()).string());
    const int base = static_cast<int>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), mesh.positions.begin(), mesh.positions.end());
    for (const Eigen::Vector3i& t : mesh.triangles) merged.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  return merged;
}

// Camera centres of calib's frames against truth, per device, through
// capture.json's source frame indices; RMSE after the best similarity.
void CameraAte(const std::string& workspace, const json& truth, CaptureScores* s) {
  const CaptureFile capture = ReadCaptureFile(CaptureFilePath(workspace));
  const CamerasFile cameras = ReadCamerasFile(workspace + "/calib/cameras.json");
  std::map<std::string, std::vector<Eigen::Vector3d>> estimated, actual;
  for (const CalibratedFrame& f : cameras.frames) {
    const CaptureFrame* frame = capture.Find(f.name);
    RELIT_REQUIRE(frame != nullptr, "calib frame ", f.name, " is not in capture.json");
    const json& t = truth.at("videos").at(f.device).at("frames").at(frame->source_frame);
    estimated[f.device].push_back(f.cam_from_world.Inverse().translation);
    actual[f.device].push_back(Vector3FromJson(t.at("camera_center_world_m")));
  }
  for (const auto& [device, points] : estimated) {
    const int n = static_cast<int>(points.size());
    RELIT_REQUIRE(n >= 3, "ATE of ", device, ": only ", n, " calibrated frames");
    Eigen::Matrix3Xd src(3, n), dst(3, n);
    for (int i = 0; i < n; ++i) {
      src.col(i) = points[i];
      dst.col(i) = actual[device][i];
    }
    const Eigen::Matrix4d sim = Eigen::umeyama(src, dst, true);
    double sum = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = sim.topLeftCorner<3, 3>() * src.col(i) + sim.topRightCorner<3, 1>();
      sum += (p - dst.col(i)).squaredNorm();
    }
    s->ate_frames[device] = n;
    s->ate_mm[device] = std::sqrt(sum / n) * 1e3;
    s->ate_scale[device] = std::cbrt(sim.topLeftCorner<3, 3>().determinant());
  }
}

}  // namespace

CaptureScores ScoreCapture(const std::string& workspace, const std::string& capture_dir) {
  const fs::path capture(capture_dir), ws(workspace);
  const json truth = ReadJsonFile((capture / "truth.json").string(), "synth_truth", 1);
  CaptureScores s;

  // capture.json times are container presentation times on phone V's file
  // clock (frame 0 at first_frame_pts_s), truth's t_common_s counts from phone
  // V's first frame: what must agree is the time between a phone L frame and a
  // phone V frame, so the error is the mean clock difference of L's frames
  // minus V's (their mean, exactly V's first-frame pts with no error).
  const CaptureFile capture_file = ReadCaptureFile(CaptureFilePath(workspace));
  s.sync_offset_s = capture_file.sync_offset_s;
  s.truth_offset_s = truth.at("light_start_offset_s").get<double>();
  const auto mean_lead = [&](const std::vector<CaptureFrame>& frames, const char* video) {
    double sum = 0;
    for (const CaptureFrame& f : frames) {
      sum += f.time_s - truth.at("videos").at(video).at("frames").at(f.source_frame).at("t_common_s").get<double>();
    }
    RELIT_REQUIRE(!frames.empty(), "capture.json has no ", video, " frames");
    return sum / frames.size();
  };
  s.sync_error_ms = (mean_lead(capture_file.light, "light") - mean_lead(capture_file.view, "view")) * 1e3;

  CameraAte(workspace, truth, &s);
  s.calib_accuracy = calib::MeasureCalibAccuracy(workspace, truth).ToJson();

  const ProxyFile proxy = ReadProxyFile((ws / "reconstruct" / "proxy.json").string());
  const render::TriangleMesh mesh = render::LoadMesh((ws / proxy.mesh).string());
  const render::TriangleMesh objects = TruthObjects(capture, truth);
  s.chamfer_mm = reconstruct::SymmetricChamferDistance(mesh, objects, 50000) * 1e3;
  s.chamfer_percent = s.chamfer_mm / (objects.Bounds().diagonal().norm() * 1e3) * 100;

  const fs::path eval_path = ws / "relight" / "eval" / "eval.json";
  RELIT_REQUIRE(fs::exists(eval_path), eval_path.string(), " is missing: did the pipeline run its eval step "
                "(inputs.truth in pipeline.yaml)?");
  const json eval = ReadJsonFile(eval_path.string(), "eval", 1);
  for (const json& row : eval.at("summary")) {
    if (row.at("light_type") != "all") continue;
    s.psnr_db[row.at("method").get<std::string>()] = row.at("psnr_db").get<double>();
    s.eval_images = row.at("images").get<int>();
  }
  RELIT_REQUIRE(!s.psnr_db.empty(), eval_path.string(), ": no \"all\" rows in its summary");
  RELIT_REQUIRE(eval.contains("truth_noise_floor"), eval_path.string(),
                ": no truth_noise_floor (the capture's eval set has no noise halves or twins)");
  s.noise_floor_db = eval["truth_noise_floor"]["per_light_type"]["all"]["psnr_db"].get<double>();
  return s;
}

json CaptureScores::ToJson() const {
  return {{"sync_offset_s", sync_offset_s}, {"truth_offset_s", truth_offset_s}, {"sync_error_ms", sync_error_ms},
          {"ate_frames", ate_frames},       {"ate_mm", ate_mm},                 {"ate_scale", ate_scale},
          {"calib_accuracy", calib_accuracy}, {"chamfer_mm", chamfer_mm},      {"chamfer_percent", chamfer_percent},
          {"psnr_db", psnr_db},             {"noise_floor_db", noise_floor_db}, {"eval_images", eval_images}};
}

std::string ScoresTable(const std::vector<std::pair<std::string, CaptureScores>>& rows) {
  struct Figure {
    std::string name;
    std::function<double(const CaptureScores&)> get;
    bool lower_is_better;
  };
  const auto device = [](const CaptureScores& s, const char* d, const char* key) {
    const json& a = s.calib_accuracy;
    return a.contains("devices") && a["devices"].contains(d) ? a["devices"][d].value(key, NAN) : NAN;
  };
  const auto map_value = [](const std::map<std::string, double>& m, const std::string& k) {
    const auto it = m.find(k);
    return it == m.end() ? NAN : it->second;
  };
  const std::vector<Figure> figures = {
      {"sync error (ms, absolute)", [](const CaptureScores& s) { return std::abs(s.sync_error_ms); }, true},
      {"phone V ATE after Sim(3) (mm)", [&](const CaptureScores& s) { return map_value(s.ate_mm, "view"); }, true},
      {"phone L ATE after Sim(3) (mm)", [&](const CaptureScores& s) { return map_value(s.ate_mm, "light"); }, true},
      {"phone V position median (mm)", [&](const CaptureScores& s) { return device(s, "view", "position_median_mm"); }, true},
      {"phone V rotation median (deg)", [&](const CaptureScores& s) { return device(s, "view", "rotation_median_deg"); }, true},
      {"flash position median (mm)", [](const CaptureScores& s) { return s.calib_accuracy["flash"].value("median_mm", NAN); }, true},
      {"proxy Chamfer (mm)", [](const CaptureScores& s) { return s.chamfer_mm; }, true},
      {"proxy Chamfer (% of diagonal)", [](const CaptureScores& s) { return s.chamfer_percent; }, true},
      {"eval PSNR, model (dB)", [&](const CaptureScores& s) { return map_value(s.psnr_db, "model"); }, false},
      {"eval PSNR, cues-only baseline (dB)", [&](const CaptureScores& s) { return map_value(s.psnr_db, "cues_only"); }, false},
      {"truth noise floor (dB)", [](const CaptureScores& s) { return s.noise_floor_db; }, false},
  };
  std::string md = "| figure |";
  for (const auto& [name, scores] : rows) md += " " + name + " |";
  md += rows.size() == 2 ? " ratio (worse / better) |\n" : "\n";
  md += "| --- |";
  for (size_t i = 0; i < rows.size() + (rows.size() == 2 ? 1 : 0); ++i) md += " --- |";
  md += "\n";
  for (const Figure& f : figures) {
    md += "| " + f.name + " |";
    std::vector<double> values;
    for (const auto& [name, scores] : rows) {
      values.push_back(f.get(scores));
      md += std::isnan(values.back()) ? " — |" : fmt::format(" {:.3g} |", values.back());
    }
    if (rows.size() == 2) {
      // PSNR: the ratio of the MSEs (10^(dB difference / 10)); others: the ratio of the values.
      double ratio = f.lower_is_better ? std::max(values[0], values[1]) / std::min(values[0], values[1])
                                       : std::pow(10.0, std::abs(values[0] - values[1]) / 10);
      md += std::isfinite(ratio) ? fmt::format(" {:.2f} |", ratio) : " — |";
    }
    md += "\n";
  }
  return md;
}

}  // namespace relit::bench
