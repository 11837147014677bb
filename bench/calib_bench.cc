// relit-bench-calib: the calib stage on a synthetic capture, side by side.
//  1. Board detection on the same frames: OpenCV 4.6 aruco vs libapriltag
//     (ms per frame, markers decoded, marker-corner error against the true
//     projection), and ChArUco corners with libapriltag off / second pass /
//     always.
//  2. Step timings of the calib run (detection, COLMAP steps, refinement)
//     from W/calib/calib_report.json.
//  3. Accuracy of W/calib against truth.json (poses, lenses, flash).
//  4. With several --workspace (copies of one capture calibrated with
//     different options, e.g. sfm.mode incremental vs board_seeded): step
//     timings and accuracy side by side, one column per workspace.
// Results and how to reproduce them: docs/benchmarks.md, section "Calib".
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/board_detect.h"
#include "calib/truth_accuracy.h"
#include "core/board.h"
#include "core/camera.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/json_file.h"

namespace relit::calib {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

struct DetectorTally {
  double ms = 0;
  int markers = 0;
  int frames_with_markers = 0;
  int markers_only_here = 0;          // decoded by this detector and not the other
  std::vector<double> corner_error_px;
};

struct CharucoTally {
  double ms = 0;
  int corners = 0;
  int frames_with_pose = 0;           // >= min_corners ChArUco corners
};

// True marker corners of `camera`'s frame, by marker id, distorted pixels.
std::map<int, std::array<Eigen::Vector2d, 4>> TrueMarkerCorners(const BoardSpec& spec, const Camera& camera) {
  const cv::Ptr<cv::aruco::CharucoBoard> board = MakeCharucoBoard(spec);
  const Rigid3 world_from_board = WorldFromBoard(spec);
  std::map<int, std::array<Eigen::Vector2d, 4>> out;
  for (size_t i = 0; i < board->ids.size(); ++i) {
    std::array<Eigen::Vector2d, 4> corners;
    bool visible = true;
    for (int c = 0; c < 4; ++c) {
      const cv::Point3f p = board->objPoints[i][c];
      visible = visible && camera.Project(world_from_board * Eigen::Vector3d(p.x, p.y, p.z), &corners[c]);
    }
    if (visible) out[board->ids[i]] = corners;
  }
  return out;
}

void TallyMarkers(const std::vector<MarkerCorners>& found, const std::vector<MarkerCorners>& other,
                  const std::map<int, std::array<Eigen::Vector2d, 4>>& truth, DetectorTally* tally) {
  tally->markers += static_cast<int>(found.size());
  tally->frames_with_markers += found.empty() ? 0 : 1;
  for (const MarkerCorners& m : found) {
    bool in_other = false;
    for (const MarkerCorners& o : other) in_other = in_other || o.id == m.id;
    tally->markers_only_here += in_other ? 0 : 1;
    const auto t = truth.find(m.id);
    if (t == truth.end()) continue;
    for (int c = 0; c < 4; ++c) tally->corner_error_px.push_back((m.corners_px[c] - t->second[c]).norm());
  }
}

struct FrameSample {
  std::string device;
  std::string path;
  Camera truth_camera;
};

std::vector<FrameSample> SampleFrames(const std::string& workspace, const json& truth, int max_frames) {
  const CaptureFile capture = ReadCaptureFile(CaptureFilePath(workspace));
  std::vector<FrameSample> samples;
  for (const std::string device : {"view", "light"}) {
    const std::vector<CaptureFrame>& frames = device == "view" ? capture.view : capture.light;
    const int count = static_cast<int>(frames.size());
    const int take = max_frames > 0 ? std::min(count, max_frames) : count;
    const Intrinsics lens = TruthLens(truth, device);  // as capture's frames show it
    for (int k = 0; k < take; ++k) {
      const CaptureFrame& f = frames[static_cast<size_t>(k) * count / take];
      FrameSample s;
      s.device = device;
      s.path = workspace + "/" + f.image;
      const json& t = truth["videos"][device]["frames"].at(f.source_frame);
      const cv::Size size = cv::imread(s.path, cv::IMREAD_UNCHANGED).size();
      RELIT_REQUIRE(size.width > 0, "cannot read ", s.path);
      s.truth_camera = Camera(lens.Scaled(size.width, size.height),
                              DisplayedCamFromWorld(Rigid3FromJson(t["cam_from_world"]),
                                                    TruthDisplayRotation(truth, device)));
      samples.push_back(s);
    }
  }
  return samples;
}

void PrintDetection(const std::vector<FrameSample>& samples, const BoardSpec& spec) {
  DetectOptions base;
  base.threads = 1;
  BoardDetector detector(spec, base);
  if (!detector.apriltag_available()) {
    std::printf("\n## Marker detection: skipped, %s is not an AprilTag family (libapriltag cannot read it)\n",
                spec.dictionary.c_str());
    return;
  }
  std::map<std::string, std::unique_ptr<BoardDetector>> charuco;
  for (const std::string mode : {"off", "second_pass", "always"}) {
    DetectOptions o = base;
    o.apriltag = mode;
    charuco[mode] = std::make_unique<BoardDetector>(spec, o);
  }
  DetectorTally opencv, apriltag;
  std::map<std::string, CharucoTally> modes;
  int truth_markers = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    cv::Mat grey = cv::imread(samples[i].path, cv::IMREAD_GRAYSCALE);
    const auto truth = TrueMarkerCorners(spec, samples[i].truth_camera);
    truth_markers += static_cast<int>(truth.size());
    auto start = Clock::now();
    const std::vector<MarkerCorners> by_opencv = detector.DetectOpenCv(grey);
    opencv.ms += MsSince(start);
    start = Clock::now();
    const std::vector<MarkerCorners> by_apriltag = detector.DetectAprilTag(grey);
    apriltag.ms += MsSince(start);
    TallyMarkers(by_opencv, by_apriltag, truth, &opencv);
    TallyMarkers(by_apriltag, by_opencv, truth, &apriltag);
    for (auto& [mode, d] : charuco) {
      start = Clock::now();
      const BoardObservation observation = d->Detect(grey);
      modes[mode].ms += MsSince(start);
      modes[mode].corners += static_cast<int>(observation.corner_ids.size());
      modes[mode].frames_with_pose += static_cast<int>(observation.corner_ids.size()) >= base.min_corners;
    }
    std::fprintf(stderr, "\rdetection %zu/%zu frames", i + 1, samples.size());
  }
  std::fprintf(stderr, "\n");
  const double n = static_cast<double>(samples.size());
  auto ratio = [](double a, double b) { return b > 0 ? a / b : NAN; };
  std::printf("\n## Marker detection, %zu frames (%s, %dx%d squares)\n\n", samples.size(),
              spec.dictionary.c_str(), spec.squares_x, spec.squares_y);
  std::printf("| | OpenCV 4.6 aruco | libapriltag | libapriltag / OpenCV |\n| --- | --- | --- | --- |\n");
  std::printf("| ms per frame (1 thread) | %.1f | %.1f | %.2f |\n", opencv.ms / n, apriltag.ms / n,
              ratio(apriltag.ms, opencv.ms));
  std::printf("| markers decoded per frame (inside the frame by truth, occlusion ignored: %.1f) | %.2f | %.2f | %.2f |\n",
              truth_markers / n, opencv.markers / n, apriltag.markers / n,
              ratio(apriltag.markers, opencv.markers));
  std::printf("| frames with a marker | %d | %d | |\n", opencv.frames_with_markers, apriltag.frames_with_markers);
  std::printf("| markers the other detector missed | %d | %d | |\n", opencv.markers_only_here,
              apriltag.markers_only_here);
  std::printf("| marker-corner error, median / p90 (px) | %.3f / %.3f | %.3f / %.3f | |\n",
              Median(opencv.corner_error_px), Quantile(opencv.corner_error_px, 0.9),
              Median(apriltag.corner_error_px), Quantile(apriltag.corner_error_px, 0.9));
  std::printf("\n## ChArUco corners (calib's full detection: OpenCV, then libapriltag as configured)\n\n");
  std::printf("| detect.apriltag | ms per frame | corners per frame | frames with >= %d corners |\n| --- | --- | --- | --- |\n",
              base.min_corners);
  for (const std::string mode : {"off", "second_pass", "always"}) {
    const CharucoTally& t = modes[mode];
    std::printf("| %s | %.1f | %.2f | %d / %zu |\n", mode.c_str(), t.ms / n, t.corners / n,
                t.frames_with_pose, samples.size());
  }
}

void PrintStepTimings(const json& report) {
  std::printf("\n## calib step timings (W/calib/calib_report.json)\n\n| step | seconds |\n| --- | --- |\n");
  for (const auto& [step, seconds] : report["timings_s"].items()) {
    std::printf("| %s | %.1f |\n", step.c_str(), seconds.get<double>());
  }
  for (const std::string device : {"view", "light", "geometry"}) {
    if (!report["detection"].contains(device)) continue;
    const json& d = report["detection"][device];
    char apriltag[96] = "not run";
    if (d.value("apriltag_frames", 0) > 0) {
      std::snprintf(apriltag, sizeof(apriltag), "%.1f ms/frame on %d frames", d.value("apriltag_ms_per_frame", 0.0),
                    d.value("apriltag_frames", 0));
    }
    std::printf("\ndetection during the run, %s: OpenCV %.1f ms/frame over %d frames; libapriltag %s\n",
                device.c_str(), d.value("opencv_ms_per_frame", 0.0), d.value("frames", 0), apriltag);
  }
}

void PrintAccuracy(const std::string& workspace, const json& truth, const json& report) {
  const CalibAccuracy a = MeasureCalibAccuracy(workspace, truth);
  std::printf("\n## Accuracy against truth.json\n\n| | frames | position median / p90 (mm) | rotation median / p90 (deg) | focal error |\n| --- | --- | --- | --- | --- |\n");
  for (const auto& [device, d] : a.devices) {
    std::printf("| %s | %d | %.2f / %.2f | %.3f / %.3f | %+.3f%% |\n", device.c_str(), d.frames,
                d.position_median_mm, d.position_p90_mm, d.rotation_median_deg, d.rotation_p90_deg,
                d.focal_error * 100);
  }
  std::printf("| flash (reliable frames) | %d | %.2f / %.2f | | |\n", a.flashes, a.flash_median_mm, a.flash_p90_mm);
  const json& refine = report["refine"];
  std::printf("\nboard-corner RMS %.3f px, SfM point RMS %s px; marker/square ratio measured %s\n",
              refine.value("corner_rms_px", NAN),
              refine.contains("point_rms_px") ? refine["point_rms_px"].dump().c_str() : "n/a",
              report["scale_check"].value("marker_to_square_measured", json()).dump().c_str());
}

std::string Cell(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

// Step timings and accuracy of several calibrated copies of one capture.
void PrintSideBySide(const std::vector<std::string>& workspaces, const json& truth) {
  std::vector<json> reports;
  std::vector<CalibAccuracy> accuracy;
  std::set<std::string> steps;
  for (const std::string& w : workspaces) {
    reports.push_back(ReadJsonFile(w + "/calib/calib_report.json", "calib_report", 1));
    accuracy.push_back(MeasureCalibAccuracy(w, truth));
    for (const auto& [step, seconds] : reports.back()["timings_s"].items()) steps.insert(step);
  }
  std::printf("\n## Side by side\n\n| |");
  for (const json& r : reports) std::printf(" %s |", r["sfm"].value("mode", std::string("no sfm")).c_str());
  std::printf("\n| --- |");
  for (size_t i = 0; i < reports.size(); ++i) std::printf(" --- |");
  std::printf("\n");
  auto row = [&](const std::string& name, const std::function<std::string(size_t)>& cell) {
    std::printf("| %s |", name.c_str());
    for (size_t i = 0; i < reports.size(); ++i) std::printf(" %s |", cell(i).c_str());
    std::printf("\n");
  };
  row("images (V / L / geometry)", [&](size_t i) {
    const json& r = reports[i]["registered"];
    return std::to_string(r.value("view_frames", 0)) + " / " + std::to_string(r.value("light_frames", 0)) + " / " +
           std::to_string(r.value("geometry_frames", 0));
  });
  row("registered", [&](size_t i) {
    const json& r = reports[i]["registered"];
    return std::to_string(r.value("view", 0) + r.value("light", 0) + r.value("geometry", 0));
  });
  row("seeded by the board", [&](size_t i) { return reports[i]["sfm"].value("seeded_frames", json(0)).dump(); });
  for (const std::string& step : steps) {
    row(step + " (s)", [&](size_t i) {
      const json& t = reports[i]["timings_s"];
      return t.contains(step) ? Cell("%.1f", t[step].get<double>()) : std::string("");
    });
  }
  // Sum of the steps (COLMAP's separately: older reports timed the joint
  // refinement inside "sfm").
  row("total of the steps (s)", [&](size_t i) {
    double total = 0;
    for (const auto& [step, seconds] : reports[i]["timings_s"].items()) {
      if (step != "sfm") total += seconds.get<double>();
    }
    return Cell("%.1f", total);
  });
  row("joint refinement solver, iterations", [&](size_t i) {
    const json& r = reports[i]["refine"];
    return r.value("linear_solver", std::string("?")) + ", " + std::to_string(r.value("iterations", 0));
  });
  row("SfM points", [&](size_t i) { return reports[i]["sfm"].value("points", json(0)).dump(); });
  for (const std::string device : {"view", "light", "geometry"}) {
    if (!accuracy[0].devices.count(device)) continue;
    row(device + " position median / p90 (mm)", [&](size_t i) {
      const DeviceAccuracy& d = accuracy[i].devices[device];
      return Cell("%.2f", d.position_median_mm) + " / " + Cell("%.2f", d.position_p90_mm);
    });
    row(device + " rotation median / p90 (deg)", [&](size_t i) {
      const DeviceAccuracy& d = accuracy[i].devices[device];
      return Cell("%.3f", d.rotation_median_deg) + " / " + Cell("%.3f", d.rotation_p90_deg);
    });
  }
  row("flash median / p90 (mm)", [&](size_t i) {
    return Cell("%.2f", accuracy[i].flash_median_mm) + " / " + Cell("%.2f", accuracy[i].flash_p90_mm);
  });
  row("board-corner RMS (px)", [&](size_t i) { return Cell("%.3f", reports[i]["refine"].value("corner_rms_px", NAN)); });
}

int Run(int argc, char** argv) {
  CLI::App app{"relit-bench-calib: detection, step timings and accuracy of calib on a synthetic capture"};
  std::vector<std::string> workspaces;
  std::string truth_path;
  int max_frames = 40;
  bool detection_only = false, skip_detection = false;
  app.add_option("--workspace", workspaces, "workspace with capture/ (and calib/ for timings and accuracy); "
                 "repeat it for copies of one capture calibrated differently (side-by-side table)")->required();
  app.add_option("--truth", truth_path, "truth.json of the synthetic capture")->required();
  app.add_option("--max-frames", max_frames, "frames per phone for the detection comparison (0 = all)");
  app.add_flag("--detection-only", detection_only, "skip the calib/ sections");
  app.add_flag("--skip-detection", skip_detection, "skip the detector comparison (section 1)");
  CLI11_PARSE(app, argc, argv);
  const json truth = ReadJsonFile(truth_path, "synth_truth", 1);
  const std::string& workspace = workspaces.front();
  if (!skip_detection) PrintDetection(SampleFrames(workspace, truth, max_frames), BoardSpecFromTruth(truth));
  if (detection_only) return 0;
  if (workspaces.size() > 1) {
    PrintSideBySide(workspaces, truth);
    return 0;
  }
  const json report = ReadJsonFile(workspace + "/calib/calib_report.json", "calib_report", 1);
  PrintStepTimings(report);
  PrintAccuracy(workspace, truth, report);
  return 0;
}

}  // namespace
}  // namespace relit::calib

int main(int argc, char** argv) {
  try {
    return relit::calib::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "relit-bench-calib: %s\n", e.what());
    return 1;
  }
}
