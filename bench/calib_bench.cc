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
//  5. --corner-bias: calib's ChArUco corners against their true projection
//     per phone (error, radial bias, error slopes, shift toward the darker
//     side and the board's far side) and the lens step on those corners and
//     on the same corners at their true pixels (issue 28).
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
#include "calib/board_pose.h"
#include "calib/calib_options.h"
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

// ChArUco corners of calib's detector against their true projection, per
// phone: is the detection biased along the radius from the principal point
// (issue 28: phone L's focal length comes out too long)? "scale" is the
// least-squares factor s of detected - c = s * (true - c), c the true
// principal point, minus 1; "radial" the mean error along (true - c).
void PrintCornerBias(const std::vector<FrameSample>& samples, const BoardSpec& spec, const std::string& refine) {
  DetectOptions options;
  options.threads = 1;
  options.corner_refine = refine;
  const BoardDetector detector(spec, options);
  const auto board = MakeCharucoBoard(spec);
  const Rigid3 world_from_board = WorldFromBoard(spec);
  std::printf("\n## ChArUco corners against truth (radial bias), detect.corner_refine %s\n\n", refine.c_str());
  std::printf("| phone | frames | corners | error median / p90 (px) | mean error x / y (px) | radial mean (px) | "
              "scale about c | radial mean at r < 60 / 60-120 / > 120 px |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const std::string device : {"view", "light"}) {
    std::vector<double> errors;
    double num = 0, den = 0, radial = 0, ex = 0, ey = 0;
    double bin_sum[3] = {0, 0, 0};
    int bin_count[3] = {0, 0, 0};
    int frames = 0, corners = 0;
    double toward_far = 0, toward_far_tilted = 0, sxx = 0, syy = 0, exx = 0, eyy = 0, exy = 0;
    int tilted = 0;
    double toward_dark = 0, slope_num = 0, slope_den = 0, gradient_sum = 0;
    std::vector<BoardObservation> detected, exact;  // calib's corners; the same corners at their true pixels
    cv::Size size;
    double truth_fx = 0;
    for (const FrameSample& s : samples) {
      if (s.device != device) continue;
      ++frames;
      const cv::Mat grey = cv::imread(s.path, cv::IMREAD_GRAYSCALE);
      size = grey.size();
      truth_fx = s.truth_camera.intrinsics().fx;
      const BoardObservation obs = detector.Detect(grey);
      BoardObservation kept, true_obs;
      // Local white level: the brightest pixel within ~a square, smoothed.
      cv::Mat white;
      cv::dilate(grey, white, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(41, 41)));
      white.convertTo(white, CV_32F);
      cv::GaussianBlur(white, white, cv::Size(0, 0), 15);
      cv::Mat log_white;
      cv::log(cv::max(white, 1.0f), log_white);
      const Eigen::Vector2d c(s.truth_camera.intrinsics().cx, s.truth_camera.intrinsics().cy);
      for (size_t i = 0; i < obs.corner_ids.size(); ++i) {
        const cv::Point3f& p = board->chessboardCorners[obs.corner_ids[i]];
        Eigen::Vector2d t;
        if (!s.truth_camera.Project(world_from_board * Eigen::Vector3d(p.x, p.y, p.z), &t)) continue;
        const Eigen::Vector2d e = obs.corners_px[i] - t;
        if (e.norm() > 3) continue;  // not that corner (occlusion, mismatch)
        {
          const int x = std::clamp(static_cast<int>(std::lround(t.x())), 5, grey.cols - 6);
          const int y = std::clamp(static_cast<int>(std::lround(t.y())), 5, grey.rows - 6);
          const Eigen::Vector2d g((log_white.at<float>(y, x + 5) - log_white.at<float>(y, x - 5)) / 10,
                                  (log_white.at<float>(y + 5, x) - log_white.at<float>(y - 5, x)) / 10);
          if (g.norm() > 1e-6) toward_dark += -e.dot(g.normalized());
          slope_num += -e.dot(g);
          slope_den += g.squaredNorm();
          gradient_sum += g.norm();
        }
        {
          // Toward the board's far side: the image direction of the board's
          // in-plane direction of steepest depth increase.
          const Eigen::Vector3d P = world_from_board * Eigen::Vector3d(p.x, p.y, p.z);
          const Eigen::Vector3d axis = s.truth_camera.world_from_cam().rotation * Eigen::Vector3d::UnitZ();
          Eigen::Vector3d d = axis - axis.z() * Eigen::Vector3d::UnitZ();
          if (d.norm() > 1e-6) {
            d.normalize();
            Eigen::Vector2d t2;
            if (s.truth_camera.Project(P + 0.002 * d, &t2)) {
              const Eigen::Vector2d u = (t2 - t).normalized();
              toward_far += e.dot(u);
              const double tilt = std::acos(std::min(1.0, std::abs(axis.z())));
              toward_far_tilted += tilt > 50 * M_PI / 180 ? e.dot(u) : 0;
              tilted += tilt > 50 * M_PI / 180;
            }
          }
        }
        kept.corner_ids.push_back(obs.corner_ids[i]);
        kept.corners_px.push_back(obs.corners_px[i]);
        true_obs.corner_ids.push_back(obs.corner_ids[i]);
        true_obs.corners_px.push_back(t);
        errors.push_back(e.norm());
        const Eigen::Vector2d tr = t - c, dr = obs.corners_px[i] - c;
        sxx += tr.x() * tr.x();
        syy += tr.y() * tr.y();
        exx += e.x() * tr.x();
        eyy += e.y() * tr.y();
        exy += e.x() * tr.y();
        num += dr.dot(tr);
        den += tr.dot(tr);
        const double rad = e.dot(tr.normalized());
        radial += rad;
        ex += e.x();
        ey += e.y();
        const int bin = tr.norm() < 60 ? 0 : tr.norm() < 120 ? 1 : 2;
        bin_sum[bin] += rad;
        ++bin_count[bin];
        ++corners;
      }
      detected.push_back(kept);
      exact.push_back(true_obs);
    }
    if (corners == 0) continue;
    auto lens_fx = [&](const std::vector<BoardObservation>& obs) {
      std::vector<const BoardObservation*> pointers;
      for (const BoardObservation& o : obs) pointers.push_back(&o);
      const CalibOptions defaults;
      const BoardCalibration c = CalibrateFromBoard(
          pointers, spec, size.width, size.height, defaults.intrinsics.refine_k3, defaults.intrinsics.square_pixels,
          defaults.intrinsics.refine_tangential, defaults.detect.min_corners, 60, device);
      return 100 * (c.intrinsics.fx / truth_fx - 1);
    };
    std::printf("lens step (calibrateCameraCharuco, calib's defaults) on %s: focal error %+.3f %% from the detected "
                "corners, %+.3f %% from the same corners at their true pixels\n",
                device.c_str(), lens_fx(detected), lens_fx(exact));
    std::printf("%s: mean error toward the darker side (local white level) %+.4f px; mean |grad log white| %.4f /px; "
                "error per unit of -grad log white %+.3f px^2\n",
                device.c_str(), toward_dark / corners, gradient_sum / corners, slope_num / slope_den);
    std::printf("%s: error slopes (%% of the offset from c): x on x %+.3f, y on y %+.3f, x on y (shear) %+.3f\n",
                device.c_str(), 100 * exx / sxx, 100 * eyy / syy, 100 * exy / syy);
    std::printf("%s: mean error toward the board's far side %+.4f px (all), %+.4f px (%d corners seen > 50 deg from the normal)\n",
                device.c_str(), toward_far / corners, toward_far_tilted / std::max(1, tilted), tilted);
    std::printf("| %s | %d | %d | %.3f / %.3f | %+.3f / %+.3f | %+.4f | %+.3f %% | %+.3f / %+.3f / %+.3f |\n",
                device.c_str(), frames, corners, Median(errors), Quantile(errors, 0.9), ex / corners, ey / corners,
                radial / corners, 100 * (num / den - 1), bin_sum[0] / std::max(1, bin_count[0]),
                bin_sum[1] / std::max(1, bin_count[1]), bin_sum[2] / std::max(1, bin_count[2]));
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
  bool detection_only = false, skip_detection = false, corner_bias = false;
  std::string corner_refine = DetectOptions().corner_refine;
  app.add_option("--workspace", workspaces, "workspace with capture/ (and calib/ for timings and accuracy); "
                 "repeat it for copies of one capture calibrated differently (side-by-side table)")->required();
  app.add_option("--truth", truth_path, "truth.json of the synthetic capture")->required();
  app.add_option("--max-frames", max_frames, "frames per phone for the detection comparison (0 = all)");
  app.add_flag("--detection-only", detection_only, "skip the calib/ sections");
  app.add_flag("--skip-detection", skip_detection, "skip the detector comparison (section 1)");
  app.add_flag("--corner-bias", corner_bias, "ChArUco corners against their true projection per phone "
               "(radial bias, scale about the principal point, the lens step on them), then stop");
  app.add_option("--corner-refine", corner_refine, "detect.corner_refine for --corner-bias")
      ->check(CLI::IsMember({"cornersubpix", "saddle"}));
  CLI11_PARSE(app, argc, argv);
  const json truth = ReadJsonFile(truth_path, "synth_truth", 1);
  const std::string& workspace = workspaces.front();
  if (corner_bias) {
    PrintCornerBias(SampleFrames(workspace, truth, max_frames), BoardSpecFromTruth(truth), corner_refine);
    return 0;
  }
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
