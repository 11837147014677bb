#include "calib/calib.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <utility>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include "calib/bundle_subset.h"
#include "calib/calib_steps.h"
#include "calib/colmap_sfm.h"
#include "calib/lights.h"
#include "calib/undistort.h"
#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/stage_cli.h"
#include "core/stage_run.h"
#include "core/workspace.h"

namespace relit::calib {

namespace {

namespace fs = std::filesystem;

constexpr const char* kReportKind = "calib_report";
constexpr int kReportVersion = 1;

BundleOptions ToBundleOptions(const CalibOptions& o, bool with_points) {
  BundleOptions b;
  b.huber_px = o.refine.huber_px;
  b.outlier_px = o.refine.outlier_px;
  b.final_huber_px = o.refine.final_huber_px;
  b.point_weight = with_points ? o.sfm.point_weight : 0.0;
  b.max_iterations = o.refine.max_iterations;
  b.threads = o.sfm.threads;
  b.linear_solver = o.refine.linear_solver;
  b.dense_schur_max_frames = o.refine.dense_schur_max_frames;
  b.iterative_eta = o.refine.iterative_eta;
  b.dense_library = o.refine.dense_library;
  b.function_tolerance = o.refine.function_tolerance;
  b.first_function_tolerance = o.refine.first_function_tolerance;
  b.first_max_iterations = o.refine.first_max_iterations;
  b.rolling_shutter = o.refine.rolling_shutter;
  b.rolling_shutter_max_gap_s = o.refine.rolling_shutter_max_gap_s;
  b.max_readout_s = o.refine.max_readout_s;
  return b;
}

nlohmann::json StatsJson(const BundleStats& s) {
  return {{"corner_rms_px", s.corner_rms_px},
          {"corner_rms_px_by_device", s.corner_rms_px_by_device},
          {"corner_observations", s.corner_observations},
          {"corner_outliers", s.corner_outliers},
          {"point_rms_px", s.point_rms_px},
          {"point_observations", s.point_observations},
          {"point_outliers", s.point_outliers},
          {"iterations", s.iterations},
          {"final_iterations", s.final_iterations},
          {"linear_solver", s.linear_solver},
          {"dense_library", s.dense_library},
          {"solve_s", s.solve_s},
          {"readout_s", s.readout_s},
          {"rolling_shutter_frames", s.moving_frames}};
}

std::string FrameFile(const std::string& dir, const CaptureFrame& frame, const std::string& ext) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.", frame.index);
  return "calib/" + dir + "/" + name + ext;
}

}  // namespace

CalibSummary RunCalibImpl(const CalibOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  const fs::path workspace(options.workspace);
  const CaptureInput input = ReadCaptureFile(options.workspace);
  StageRun run({"relit-calib", workspace / "calib", options.force, {}, "--workspace", "calib.log",
                ParseLogLevel(options.log_level)});
  const fs::path root = run.path();
  RunRecord& record = run.record();
  record.SetOptions(OptionsToJson(options));
  record.AddInput("capture", (workspace / "capture" / "capture.json").string());
  nlohmann::json report;
  std::map<std::string, double> colmap_timings;

  // 1. Board detection on every frame of both phones.
  const BoardDetector detector(options.board, options.detect);
  if (options.detect.apriltag != "off" && !detector.apriltag_available()) {
    spdlog::info("detect: {} is not an AprilTag dictionary: OpenCV only", options.board.dictionary);
  }
  std::vector<CaptureFrame> all = input.view;
  all.insert(all.end(), input.light.begin(), input.light.end());
  all.insert(all.end(), input.geometry.begin(), input.geometry.end());  // optional geometry pass
  const bool geometry_pass = !input.geometry.empty();
  std::vector<CalibFrame> frames;
  {
    auto timer = record.Time("detect");
    frames = DetectAll(options.workspace, all, detector, options.detect.threads, "detect board");
  }
  RequireBoardSeen(frames, options.board, detector, options.detect.min_corners);
  for (const std::string device : {"view", "light", "geometry"}) {
    if (device == "geometry" && !geometry_pass) continue;
    report["detection"][device] = DetectionReport(frames, device, options.detect.min_corners);
  }

  // 2. Lenses and board poses.
  BundleProblem problem;
  problem.corners_world = CharucoCornersWorld(options.board);
  problem.refine_k3 = options.intrinsics.refine_k3;
  problem.square_pixels = options.intrinsics.square_pixels;
  problem.refine_tangential = options.intrinsics.refine_tangential;
  {
    auto timer = record.Time("intrinsics");
    const std::map<std::string, std::pair<int, int>> sizes = {
        {"view", {input.view_width_px, input.view_height_px}},
        {"light", {input.light_width_px, input.light_height_px}}};
    for (const auto& [device, size] : sizes) {
      bool fixed = false;
      const BoardCalibration c = InitialLens(frames, device, size.first, size.second, options, detector,
                                             &fixed, &report["intrinsics_initial"][device]);
      problem.devices[device] = c.intrinsics;
      problem.fixed_lens[device] = fixed;
    }
  }
  int board_posed = 0;
  for (const CalibFrame& f : frames) {
    BundleFrame b;
    b.device = LensOf(f.capture.device);
    b.corner_ids = f.board.corner_ids;
    b.corners_px = f.board.corners_px;
    // Photos of a geometry pass have no clock: read as global-shutter stills.
    const CaptureSource& source = input.sources.at(f.capture.device);
    b.video = source.type == "photos" ? "" : f.capture.device;
    b.time_s = f.capture.time_s;
    b.rotation_deg = source.rotation_deg;
    double rms = 0;
    b.posed = BoardPose(f.board, problem.devices.at(b.device), options.board, options.detect.min_corners,
                        &b.cam_from_world, &rms);
    board_posed += b.posed;
    problem.frames.push_back(b);
  }
  std::vector<bool> posed_by_board;
  for (const BundleFrame& b : problem.frames) posed_by_board.push_back(b.posed);
  BundleStats stats;
  {
    auto timer = record.Time("refine_board");
    stats = RefineBundle(&problem, ToBundleOptions(options, false));
  }
  report["refine_board_only"] = StatsJson(stats);
  spdlog::info("refine (board only): {} frames, corner RMS {:.3f} px", board_posed, stats.corner_rms_px);
  // The board's shape is known now: a wrong board config fails before COLMAP runs.
  CalibSummary summary;
  report["scale_check"] = CheckBoardScale(frames, problem, options, &summary.marker_ratio_measured);

  // 3. Structure from motion, aligned to the board, then the joint refinement.
  SubsetStats subset;
  if (options.sfm.enabled) {
    {
      auto timer = record.Time("sfm");  // COLMAP and the alignment, not the joint refinement
      report["sfm"] = AddStructureFromMotion(frames, options.workspace, (root / "sfm").string(), options,
                                             &problem, &colmap_timings);
    }
    for (const auto& [step, seconds] : colmap_timings) record.AddTiming(step, seconds);
    auto refine_timer = record.Time("refine_joint");
    stats = RefineBundleOnKeyFrames(&problem, ToBundleOptions(options, true), options.refine.max_joint_frames,
                                    &subset);
  } else {
    report["sfm"] = {{"ran", false}};
  }
  report["refine"] = StatsJson(stats);
  if (subset.key_frames > 0) {
    report["refine"]["key_frames"] = subset.key_frames;
    report["refine"]["placed_frames"] = subset.placed_frames;
    report["refine"]["joint_s"] = subset.joint_s;
    report["refine"]["placement_s"] = subset.placement_s;
  }
  if (geometry_pass) {
    report["geometry"] = GeometryPassReport(frames, problem, posed_by_board, stats, report["sfm"],
                                            options.detect.min_corners);
    spdlog::info("geometry pass: {} of {} frames registered ({} by the board, {} in the COLMAP model), corner "
                 "RMS {:.3f} px", report["geometry"]["registered"].get<int>(), input.geometry.size(),
                 report["geometry"]["posed_by_board"].get<int>(), report["geometry"]["registered_by_sfm"].get<int>(),
                 report["geometry"]["corner_rms_px"].get<double>());
  }

  // 4. Checks of the result.
  for (size_t i = 0; i < frames.size(); ++i) {
    summary.frames[frames[i].capture.device]++;
    summary.registered[frames[i].capture.device] += problem.frames[i].posed;
  }
  for (const std::string device : {"view", "light"}) {
    RELIT_REQUIRE(summary.registered[device] > 0, "no phone ", device == "view" ? "V" : "L",
                  " frame could be registered (board or SfM): see ", (workspace / "calib").string(),
                  " after fixing the capture");
    const double rms = stats.corner_rms_px_by_device.count(device) ? stats.corner_rms_px_by_device.at(device) : 0;
    RELIT_REQUIRE(rms <= options.refine.max_corner_rms_px, "calibration rejected: board corners of phone ",
                  device == "view" ? "V" : "L", " reproject with RMS ", rms, " px (refine.max_corner_rms_px = ",
                  options.refine.max_corner_rms_px, "). Check the board settings (squares_x/squares_y, "
                  "square_length_m, marker_length_m) in the --config file");
  }

  // 5. Light positions for every registered phone V frame.
  std::vector<TimedPose> light_poses;
  std::vector<TimedName> view_frames;
  std::vector<Eigen::Vector3d> view_centres;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (!problem.frames[i].posed) continue;
    if (frames[i].capture.device == "light") {
      light_poses.push_back({frames[i].capture.time_s, problem.frames[i].cam_from_world});
    } else if (frames[i].capture.device == "view") {  // the geometry pass gets no light
      view_frames.push_back({frames[i].capture.name, frames[i].capture.time_s});
      view_centres.push_back(problem.frames[i].cam_from_world.Inverse().translation);
    }
  }
  const Eigen::Vector3d flash_offset(options.light.flash_offset_m[0], options.light.flash_offset_m[1],
                                     options.light.flash_offset_m[2]);
  const LightsFile lights = InterpolateLights(view_frames, light_poses, flash_offset, options.light.max_gap_s);
  std::vector<Eigen::Vector3d> light_positions;
  nlohmann::json unreliable = nlohmann::json::array();
  double max_gap = 0;
  for (const FrameLight& l : lights.frames) {
    light_positions.push_back(l.position_m);
    max_gap = std::max(max_gap, l.nearest_light_gap_s);
    if (!l.reliable) unreliable.push_back({{"view_frame", l.view_frame}, {"gap_s", l.nearest_light_gap_s}});
  }
  summary.lights = static_cast<int>(lights.frames.size());
  summary.unreliable_lights = static_cast<int>(unreliable.size());
  report["lights"] = {{"frames", lights.frames.size()},
                      {"registered_light_frames", light_poses.size()},
                      {"max_gap_s", max_gap},
                      {"max_gap_allowed_s", options.light.max_gap_s},
                      {"unreliable", unreliable}};
  report["coverage"] = CoverageSummary(view_centres, light_positions, Eigen::Vector3d::Zero());

  // 6. Undistorted phone V frames and the output files.
  CamerasFile cameras;
  cameras.board = options.board;
  cameras.devices = problem.devices;
  if (geometry_pass) cameras.devices["geometry"] = problem.devices.at(LensOf("geometry"));
  cameras.undistorted_view = PinholeFor(problem.devices.at("view"), options.undistort.alpha);
  std::vector<std::pair<std::string, std::string>> model_images;
  std::vector<Rigid3> model_poses;
  nlohmann::json unposed = nlohmann::json::array();
  nlohmann::json unregistered_reasons = nlohmann::json::object();
  for (size_t i = 0; i < frames.size(); ++i) {
    const CaptureFrame& c = frames[i].capture;
    if (!problem.frames[i].posed) {
      unposed.push_back(c.name);
      unregistered_reasons[c.name] = UnregisteredReason(frames[i], posed_by_board[i], report["sfm"],
                                                        options.detect.min_corners, detector.marker_count());
      spdlog::info("calib: {} not registered: {}", c.name, unregistered_reasons[c.name].get<std::string>());
      continue;
    }
    CalibratedFrame f;
    f.name = c.name;
    f.device = c.device;
    f.time_s = c.time_s;
    f.cam_from_world = problem.frames[i].cam_from_world;
    if (c.device == "view") {
      f.image_linear = FrameFile("view_linear", c, "exr");
      f.image_8bit = FrameFile("view", c, "png");
    } else if (c.device == "geometry") {  // 8-bit only: the proxy is built from it
      f.image_8bit = FrameFile("geometry", c, "png");
    }
    cameras.frames.push_back(f);
    model_images.push_back({c.image.substr(c.image.find('/') + 1), c.device});
    model_poses.push_back(f.cam_from_world);
  }
  if (options.undistort.write_images) {
    auto timer = record.Time("undistort");
    const FrameUndistorter undistorter(problem.devices.at("view"), cameras.undistorted_view,
                                       options.undistort.interpolation);
    Progress progress("undistort", static_cast<int64_t>(cameras.frames.size()));
    std::map<std::string, const CaptureFrame*> by_name;
    for (const CaptureFrame& c : input.view) by_name[c.name] = &c;
    for (const CaptureFrame& c : input.geometry) by_name[c.name] = &c;
    tbb::parallel_for(size_t(0), cameras.frames.size(), [&](size_t i) {
      const CalibratedFrame& f = cameras.frames[i];
      if (f.device == "light") return;
      const CaptureFrame& c = *by_name.at(f.name);
      if (f.device == "geometry") {
        undistorter.RunSrgb((workspace / c.image).string(), (root / f.image_8bit.substr(6)).string());
      } else {
        undistorter.Run((workspace / c.linear).string(), (workspace / c.image).string(),
                        (root / f.image_linear.substr(6)).string(), (root / f.image_8bit.substr(6)).string());
      }
      progress.Advance();
    });
    progress.Finish();
  }
  std::vector<Eigen::Vector3d> points;
  for (const BundlePoint& p : problem.points) points.push_back(p.position_m);
  // Every SfM point, refined or not: reconstruct's sparse proxy reads them.
  points.insert(points.end(), problem.unrefined_points_m.begin(), problem.unrefined_points_m.end());
  WriteColmapTextModel((root / "model").string(), cameras.devices, model_images, model_poses, points);
  WriteCamerasFile((root / "cameras.json").string(), cameras);
  WriteLightsFile((root / "lights.json").string(), lights);

  summary.corner_rms_px = stats.corner_rms_px;
  summary.point_rms_px = stats.point_rms_px;
  summary.sfm_registered = report["sfm"].value("registered", 0);
  report["registered"] = {{"view", summary.registered["view"]},
                          {"view_frames", summary.frames["view"]},
                          {"light", summary.registered["light"]},
                          {"light_frames", summary.frames["light"]},
                          {"frames_posed_by_board", board_posed},
                          {"unposed", unposed},
                          {"unregistered_reasons", unregistered_reasons}};
  if (geometry_pass) {
    report["registered"]["geometry"] = summary.registered["geometry"];
    report["registered"]["geometry_frames"] = summary.frames["geometry"];
  }
  report["intrinsics"] = {{"view", ToJson(problem.devices.at("view"))},
                          {"light", ToJson(problem.devices.at("light"))},
                          {"undistorted_view", ToJson(cameras.undistorted_view)}};
  report["timings_s"] = record.ToJson()["timings_s"];
  WriteJsonFile((root / "calib_report.json").string(), kReportKind, kReportVersion, report);

  summary.seconds = SecondsSince(start);
  spdlog::info("timings: detection OpenCV {:.2f} ms/frame, libapriltag {} | {}",
               report["detection"]["view"]["opencv_ms_per_frame"].get<double>(),
               report["detection"]["view"]["apriltag_frames"].get<int>() > 0
                   ? fmt::format("{:.2f} ms/frame", report["detection"]["view"]["apriltag_ms_per_frame"].get<double>())
                   : std::string("not run"),
               report["timings_s"].dump());
  spdlog::info("relit-calib: wrote {} (phone V {}/{} frames, phone L {}/{} registered, corner RMS {:.3f} px, "
               "SfM point RMS {:.3f} px, {} lights, {} unreliable) in {:.1f} s",
               (workspace / "calib").string(), summary.registered["view"], summary.frames["view"],
               summary.registered["light"], summary.frames["light"], summary.corner_rms_px, summary.point_rms_px,
               summary.lights, summary.unreliable_lights, summary.seconds);
  record.Set("registered", summary.registered);
  record.Set("corner_rms_px", summary.corner_rms_px);
  run.Commit();
  summary.out_dir = (workspace / "calib").string();
  return summary;
}

int RunCalib(int argc, char** argv) {
  CLI::App app{"relit-calib: calibrate both phones against the ChArUco board, register every frame "
               "(board + COLMAP), place phone L's flash for every phone V frame. Reads W/capture, "
               "writes W/calib. See docs/calib.md."};
  StageCommandLine cli("calib", "reads W/capture, writes W/calib");
  bool no_sfm = false;
  cli.AddWorkspaceAndConfig(app);
  app.add_flag("--no-sfm", no_sfm, "board poses only, no COLMAP (sfm.enabled: false)");
  cli.AddLogLevelAndForce(app);
  CLI11_PARSE(app, argc, argv);
  CalibOptions options = cli.ReadOptions<CalibOptions>();
  if (no_sfm) options.sfm.enabled = false;
  return cli.RunStage(std::move(options), RunCalibImpl);
}

}  // namespace relit::calib
