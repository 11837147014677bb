#include "bench/relight_ladder.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <system_error>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "calib/truth_accuracy.h"
#include "calib/undistort.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/render/mesh.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"

namespace relit::bench {

namespace fs = std::filesystem;
using nlohmann::json;

std::string RungDescription(char rung, double offset_mm) {
  switch (rung) {
    case 'a': return "true cameras, lenses and flash; true mesh; true mattes";
    case 'b': return "calibrated cameras and flash; true mesh; true mattes";
    case 'c': return "calibrated; the stage's proxy; true mattes";
    case 'd': return "calibrated; the stage's proxy and mattes (the whole pipeline)";
    case 'o': {
      char text[96];
      std::snprintf(text, sizeof(text), "calibrated; the true mesh moved %s by %.2f mm; true mattes",
                    offset_mm >= 0 ? "out" : "in", std::abs(offset_mm));
      return text;
    }
  }
  throw Error(std::string("unknown ladder rung '") + rung + "' (a, b, c, d or o)");
}

void LinkTree(const fs::path& from, const fs::path& to) {
  RELIT_REQUIRE(fs::is_directory(from), from.string(), " is not a folder: run the pipeline up to reconstruct first");
  fs::create_directories(to.parent_path());
  std::error_code error;
  fs::copy(from, to, fs::copy_options::recursive | fs::copy_options::create_hard_links, error);
  if (!error) return;
  fs::remove_all(to);  // another file system: hard links are not possible
  fs::copy(from, to, fs::copy_options::recursive);
}

namespace {

// The truth's lens of `phone` at the size calib saw the frames.
Intrinsics TruthLensAt(const json& truth, const std::string& phone, const Intrinsics& calibrated) {
  Intrinsics lens = calib::TruthLens(truth, phone);
  if (lens.width != calibrated.width || lens.height != calibrated.height) {
    lens = lens.Scaled(calibrated.width, calibrated.height);  // capture downscaled the video
  }
  return lens;
}

}  // namespace

void WriteTruthCalib(const fs::path& source_workspace, const json& truth, const fs::path& rung_workspace) {
  const std::string capture_path = CaptureFilePath(rung_workspace.string());
  const CaptureFile capture = ReadCaptureFile(capture_path);
  CamerasFile cameras = ReadCamerasFile((source_workspace / "calib" / "cameras.json").string());
  LightsFile lights = ReadLightsFile((source_workspace / "calib" / "lights.json").string());

  cameras.devices.erase("geometry");
  for (auto& [device, lens] : cameras.devices) lens = TruthLensAt(truth, device, lens);
  std::vector<CalibratedFrame> frames;
  for (CalibratedFrame f : cameras.frames) {
    if (f.device == "geometry") continue;
    const json& t = calib::TruthFrameOf(capture, capture_path, truth, f.device, f.name);
    f.cam_from_world = calib::DisplayedCamFromWorld(Rigid3FromJson(t.at("cam_from_world")),
                                                    calib::TruthDisplayRotation(truth, f.device));
    frames.push_back(f);
  }
  cameras.frames = frames;

  const std::vector<double> offset = calib::TruthFlashOffset(truth);
  lights.flash_offset_m = Eigen::Vector3d(offset[0], offset[1], offset[2]);
  for (FrameLight& l : lights.frames) {
    l.position_m = Vector3FromJson(
        calib::TruthFrameOf(capture, capture_path, truth, "view", l.view_frame).at("light_position_world_m"));
    l.nearest_light_gap_s = 0;
    l.reliable = true;
  }

  // The phone V frames again, undistorted with the true lens into the same
  // pinhole camera (so every rung's images have the same size and focal).
  const fs::path calib_dir = rung_workspace / "calib";
  const calib::FrameUndistorter undistorter(cameras.devices.at("view"), cameras.undistorted_view);
  std::vector<const CalibratedFrame*> views = cameras.FramesOf("view");
  tbb::parallel_for(size_t(0), views.size(), [&](size_t i) {
    const CalibratedFrame& f = *views[i];
    const CaptureFrame* c = capture.Find(f.name);
    RELIT_REQUIRE(c != nullptr && !c->linear.empty(), "capture.json has no linear image of ", f.name);
    undistorter.Run((rung_workspace / c->linear).string(), (rung_workspace / c->image).string(),
                    (rung_workspace / f.image_linear).string(), (rung_workspace / f.image_8bit).string());
  });
  WriteCamerasFile((calib_dir / "cameras.json").string(), cameras);
  WriteLightsFile((calib_dir / "lights.json").string(), lights);
}

int WriteTruthMattes(const fs::path& rung_workspace, const fs::path& synth_dir, const json& truth) {
  const std::string capture_path = CaptureFilePath(rung_workspace.string());
  const CaptureFile capture = ReadCaptureFile(capture_path);
  const CamerasFile cameras = ReadCamerasFile((rung_workspace / "calib" / "cameras.json").string());
  const ProxyFile proxy = ReadProxyFile((rung_workspace / "reconstruct" / "proxy.json").string());
  const Intrinsics& lens = cameras.devices.at("view");
  const calib::FrameUndistorter undistorter(lens, cameras.undistorted_view);
  const int rotation_deg = calib::TruthDisplayRotation(truth, "view");
  tbb::parallel_for(size_t(0), proxy.mattes.size(), [&](size_t i) {
    const ViewMatte& m = proxy.mattes[i];
    const json& t = calib::TruthFrameOf(capture, capture_path, truth, "view", m.view_frame);
    RELIT_REQUIRE(t.contains("alpha"), "truth.json has no alpha for ", m.view_frame,
                  ": render the capture with relit-synth's default truth output");
    cv::Mat undistorted = undistorter.Remap(calib::DisplayedTruthAlpha(
        (synth_dir / t.at("alpha").get<std::string>()).string(), rotation_deg, lens.width, lens.height));
    cv::min(cv::max(undistorted, 0.0), 1.0, undistorted);
    WriteImage((rung_workspace / m.matte).string(), Image::FromMat(undistorted), PixelStorage::kUint16);
  });
  return static_cast<int>(proxy.mattes.size());
}

std::string TruthObjectMesh(const fs::path& synth_dir, const json& truth, const fs::path& work_dir) {
  const json& objects = truth.at("objects");
  RELIT_REQUIRE(objects.is_array() && !objects.empty(), "truth.json lists no objects");
  if (objects.size() == 1) return (synth_dir / objects[0].at("mesh").get<std::string>()).string();
  render::TriangleMesh merged;
  for (const json& object : objects) {
    const render::TriangleMesh mesh = render::LoadMesh((synth_dir / object.at("mesh").get<std::string>()).string());
    const int base = static_cast<int>(merged.positions.size());
    merged.positions.insert(merged.positions.end(), mesh.positions.begin(), mesh.positions.end());
    for (const Eigen::Vector3i& t : mesh.triangles) merged.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  }
  const fs::path path = work_dir / "truth_objects.obj";
  fs::create_directories(work_dir);
  render::SaveMesh(path.string(), merged);
  return path.string();
}

YAML::Node TrueMeshReconstructOptions(const YAML::Node& reconstruct) {
  YAML::Node options = reconstruct.IsMap() ? YAML::Clone(reconstruct) : YAML::Node(YAML::NodeType::Map);
  options["normal_map"]["enabled"] = false;
  return options;
}

render::TriangleMesh OffsetAlongNormals(const render::TriangleMesh& mesh, double offset_m) {
  // Welded first: an OBJ's UV seams repeat positions, and copies moved along
  // their own one-sided normals would open cracks.
  std::vector<int> welded_index;
  render::TriangleMesh welded = reconstruct::WeldEqualPositions(mesh, &welded_index);
  welded.ComputeVertexNormals();
  render::TriangleMesh moved = mesh;
  moved.normals.clear();
  for (size_t i = 0; i < moved.positions.size(); ++i) {
    moved.positions[i] += static_cast<float>(offset_m) * welded.normals[welded_index[i]];
  }
  return moved;
}

std::string OffsetTruthMesh(const fs::path& synth_dir, const json& truth, double offset_m, const fs::path& work_dir) {
  const render::TriangleMesh mesh = render::LoadMesh(TruthObjectMesh(synth_dir, truth, work_dir));
  const fs::path path = work_dir / "truth_objects_offset.obj";
  fs::create_directories(work_dir);
  render::SaveMesh(path.string(), OffsetAlongNormals(mesh, offset_m));
  return path.string();
}

namespace {

// The row of eval.json's `table` ("summary" or "summary_by_view_set"), or null.
const json* FindSummary(const json& eval, const std::string& table, const std::string& method,
                        const std::string& light_type, const std::string& view_set) {
  if (!eval.contains(table) || !eval[table].is_array()) return nullptr;
  for (const json& row : eval[table]) {
    if (row.value("method", "") != method || row.value("light_type", "") != light_type) continue;
    if (!view_set.empty() && row.value("view_set", "") != view_set) continue;
    return &row;
  }
  return nullptr;
}

double Psnr(const json& eval, const std::string& method, const std::string& light_type,
            const std::string& view_set = "") {
  const json* row =
      FindSummary(eval, view_set.empty() ? "summary" : "summary_by_view_set", method, light_type, view_set);
  return row && row->contains("psnr_db") && (*row)["psnr_db"].is_number() ? (*row)["psnr_db"].get<double>() : NAN;
}

std::string Cell(const json& scores, const std::string& key) {
  if (!scores.contains(key) || !scores[key].is_number()) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), key.find("alpha") != std::string::npos ? "%.4f" : "%.2f",
                scores[key].get<double>());
  return text;
}

}  // namespace

json RungScores(const json& eval) {
  json scores = json::object();
  auto put = [&](const std::string& key, double value) {
    if (std::isfinite(value)) scores[key] = value;  // absent when eval did not score it
  };
  for (const char* type : {"point", "directional", "environment", "all"}) {
    put(std::string("model_") + type, Psnr(eval, "model", type));
  }
  put("model_interpolation_all", Psnr(eval, "model", "all", "interpolation"));
  put("model_extrapolation_all", Psnr(eval, "model", "all", "extrapolation"));
  put("cue_fit_all", Psnr(eval, "cue_fit", "all"));
  put("cue_fit_interpolation_all", Psnr(eval, "cue_fit", "all", "interpolation"));
  put("cues_only_all", Psnr(eval, "cues_only", "all"));
  put("cues_only_interpolation_all", Psnr(eval, "cues_only", "all", "interpolation"));
  auto number = [](const json& object, const std::string& key) {
    return object.contains(key) && object[key].is_number() ? object[key].get<double>() : NAN;
  };
  if (const json* row = FindSummary(eval, "summary", "model", "all", "")) put("alpha_mae_model", number(*row, "alpha_mae"));
  if (const json* row = FindSummary(eval, "summary", "cues_only", "all", "")) {
    put("alpha_mae_coverage", number(*row, "alpha_mae"));
  }
  const json floor = eval.value("truth_noise_floor", json::object()).value("per_light_type", json::object());
  if (floor.contains("all")) put("truth_noise_floor_all", number(floor["all"], "psnr_db"));
  return scores;
}

std::string LadderTable(const json& scores) {
  std::ostringstream out;
  out << "PSNR dB (eval: clipped linear radiance on the true foreground); model per light type over all eval views, "
         "then 'all' on the interpolation views; cue fit and cues-only 'all'.\n\n"
      << "| rung | inputs | point | directional | environment | all | interpolation | extrapolation | cue fit | "
         "cues-only | alpha MAE model / coverage |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const char rung : std::string(kAllLadderRungs)) {
    const std::string key(1, rung);
    if (!scores.contains(key)) continue;
    const json& s = scores[key];
    out << "| (" << rung << ") | " << RungDescription(rung, s.value("offset_mm", 1.0)) << " | "
        << Cell(s, "model_point") << " | "
        << Cell(s, "model_directional") << " | " << Cell(s, "model_environment") << " | " << Cell(s, "model_all")
        << " | " << Cell(s, "model_interpolation_all") << " | " << Cell(s, "model_extrapolation_all") << " | "
        << Cell(s, "cue_fit_all") << " | " << Cell(s, "cues_only_all") << " | " << Cell(s, "alpha_mae_model")
        << " / " << Cell(s, "alpha_mae_coverage") << " |\n";
  }
  // What each stage costs: the model's interpolation 'all' between neighbours.
  const std::map<std::string, std::string> stage = {{"ab", "calib (cameras, lenses, flash)"},
                                                    {"bc", "reconstruct's proxy"},
                                                    {"cd", "reconstruct's mattes"},
                                                    {"bo", "the true mesh moved by rung o's offset"}};
  std::string costs;
  for (const auto& [pair, what] : stage) {
    const std::string from(1, pair[0]), to(1, pair[1]);
    if (!scores.contains(from) || !scores.contains(to)) continue;
    const json& a = scores[from];
    const json& b = scores[to];
    if (!a.contains("model_interpolation_all") || !b.contains("model_interpolation_all")) continue;
    char line[160];
    std::snprintf(line, sizeof(line), "- %s: %+.2f dB (model, interpolation views, %s -> %s)\n", what.c_str(),
                  b["model_interpolation_all"].get<double>() - a["model_interpolation_all"].get<double>(),
                  from.c_str(), to.c_str());
    costs += line;
  }
  if (!costs.empty()) out << "\nWhat each stage costs:\n" << costs;
  return out.str();
}

}  // namespace relit::bench
