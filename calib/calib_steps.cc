#include "calib/calib_steps.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "calib/align.h"
#include "calib/colmap_sfm.h"
#include "core/error.h"
#include "core/median.h"
#include "core/progress.h"

namespace relit::calib {

namespace {

namespace fs = std::filesystem;

std::string SfmName(const CaptureFrame& frame) {
  // capture/view/000003.png -> view/000003.png (relative to W/capture).
  const std::string prefix = "capture/";
  return frame.image.rfind(prefix, 0) == 0 ? frame.image.substr(prefix.size()) : frame.image;
}

}  // namespace

std::vector<CalibFrame> DetectAll(const std::string& workspace, const std::vector<CaptureFrame>& frames,
                                  const BoardDetector& detector, int threads, const std::string& label) {
  std::vector<CalibFrame> result(frames.size());
  Progress progress(label, static_cast<int64_t>(frames.size()));
  const int n = threads > 0 ? threads : static_cast<int>(tbb::global_control::active_value(
                                            tbb::global_control::max_allowed_parallelism));
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, n);
  std::vector<std::string> errors(frames.size());
  tbb::parallel_for(size_t(0), frames.size(), [&](size_t i) {
    result[i].capture = frames[i];
    const std::string path = (fs::path(workspace) / frames[i].image).string();
    const cv::Mat grey = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (grey.empty()) {
      errors[i] = "cannot read " + path + ": rerun relit-capture";
    } else {
      result[i].board = detector.Detect(grey);
    }
    progress.Advance();
  });
  progress.Finish();
  for (const std::string& e : errors) RELIT_REQUIRE(e.empty(), e);
  return result;
}

void RequireBoardSeen(const std::vector<CalibFrame>& frames, const BoardSpec& spec,
                      const BoardDetector& detector, int min_corners) {
  int markers = 0, frames_with_markers = 0, candidates = 0, best_corners = 0;
  for (const CalibFrame& f : frames) {
    markers += static_cast<int>(f.board.markers.size());
    frames_with_markers += f.board.markers.empty() ? 0 : 1;
    candidates += f.board.rejected_candidates;
    best_corners = std::max(best_corners, static_cast<int>(f.board.corner_ids.size()));
  }
  RELIT_REQUIRE(best_corners >= min_corners, "board never detected: in ", frames.size(),
                " frames of both phones, ", markers, " markers of dictionary ", spec.dictionary,
                " were found (in ", frames_with_markers, " frames; ", candidates,
                " square candidates did not decode as ", spec.dictionary, "), at most ", best_corners,
                " ChArUco corners in one frame, ", min_corners, " needed. Expected a ", spec.squares_x, "x",
                spec.squares_y, " board with ", detector.marker_count(), " markers of ", spec.dictionary,
                ": check board.dictionary and board.squares_x/squares_y in the --config file");
}

nlohmann::json DetectionReport(const std::vector<CalibFrame>& frames, const std::string& device,
                               int min_corners) {
  int count = 0, with_board = 0, apriltag_frames = 0, apriltag_added = 0;
  double opencv_ms = 0, apriltag_ms = 0, markers = 0, corners = 0;
  int single_marker_corners = 0;
  std::vector<int> seen;  // markers per frame that shows any: a shadowed board shows few
  for (const CalibFrame& f : frames) {
    if (f.capture.device != device) continue;
    ++count;
    if (!f.board.markers.empty()) seen.push_back(static_cast<int>(f.board.markers.size()));
    with_board += static_cast<int>(f.board.corner_ids.size()) >= min_corners;
    markers += f.board.markers.size();
    corners += f.board.corner_ids.size();
    single_marker_corners += f.board.corners_single_marker;
    opencv_ms += f.board.opencv_ms;
    if (f.board.apriltag_ran) {
      ++apriltag_frames;
      apriltag_ms += f.board.apriltag_ms;
      apriltag_added += f.board.markers_apriltag_added;
    }
  }
  const double n = std::max(1, count);
  std::sort(seen.begin(), seen.end());
  return {{"frames", count},
          {"frames_with_board", with_board},
          {"mean_markers", markers / n},
          {"markers_min_median_max", seen.empty() ? std::vector<int>{0, 0, 0}
                                                  : std::vector<int>{seen.front(), seen[seen.size() / 2],
                                                                     seen.back()}},
          {"mean_corners", corners / n},
          {"corners_next_to_one_marker", single_marker_corners},
          {"opencv_ms_per_frame", opencv_ms / n},
          {"apriltag_frames", apriltag_frames},
          {"apriltag_ms_per_frame", apriltag_frames > 0 ? apriltag_ms / apriltag_frames : 0.0},
          {"apriltag_markers_added", apriltag_added}};
}

BoardCalibration InitialLens(const std::vector<CalibFrame>& frames, const std::string& device, int width,
                             int height, const CalibOptions& options, const BoardDetector& detector,
                             bool* fixed, nlohmann::json* report) {
  const std::string& folder =
      device == "view" ? options.intrinsics.view_board_images : options.intrinsics.light_board_images;
  std::vector<const BoardObservation*> observations;
  std::vector<CalibFrame> clip;
  *fixed = !folder.empty();
  if (*fixed) {
    RELIT_REQUIRE(fs::is_directory(folder), "intrinsics.", device, "_board_images: ", folder,
                  " is not a folder");
    std::vector<CaptureFrame> images;
    for (const auto& entry : fs::directory_iterator(folder)) {
      const std::string ext = entry.path().extension().string();
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".PNG" || ext == ".JPG") {
        CaptureFrame f;
        f.device = device;
        f.image = fs::absolute(entry.path()).string();
        images.push_back(f);
      }
    }
    std::sort(images.begin(), images.end(), [](auto& a, auto& b) { return a.image < b.image; });
    RELIT_REQUIRE(!images.empty(), "intrinsics.", device, "_board_images: ", folder, " holds no PNG/JPEG");
    const cv::Mat first = cv::imread(images.front().image, cv::IMREAD_GRAYSCALE);
    RELIT_REQUIRE(first.cols == width && first.rows == height, "intrinsics.", device, "_board_images: ",
                  images.front().image, " is ", first.cols, "x", first.rows, " but the capture frames are ",
                  width, "x", height, ": export the board clip at the capture resolution");
    clip = DetectAll("", images, detector, options.detect.threads, "detect " + device + " board clip");
    for (const CalibFrame& f : clip) observations.push_back(&f.board);
  } else {
    for (const CalibFrame& f : frames) {
      if (f.capture.device == device) observations.push_back(&f.board);
    }
  }
  const BoardCalibration c = CalibrateFromBoard(observations, options.board, width, height,
                                                options.intrinsics.refine_k3, options.intrinsics.square_pixels,
                                                options.intrinsics.refine_tangential,
                                                options.detect.min_corners,
                                                60, device);
  *report = {{"source", *fixed ? "board images " + folder : "capture frames"},
             {"frames_used", c.frames_used},
             {"rms_px", c.rms_px},
             {"corners_used", c.corners_used},
             {"corners_rejected", c.corners_rejected},
             {"board_view_angle_span_deg", c.view_angle_span_deg},
             {"fixed_in_refinement", *fixed}};
  spdlog::info("lens {}: f = {:.2f}, {:.2f} px, c = {:.2f}, {:.2f} px, RMS {:.3f} px over {} frames, "
               "{} outlier corners dropped ({})",
               device, c.intrinsics.fx, c.intrinsics.fy, c.intrinsics.cx, c.intrinsics.cy, c.rms_px,
               c.frames_used, c.corners_rejected, *fixed ? "board images" : "capture frames");
  return c;
}

std::string ResolveSfmMode(const SfmOptions& so, size_t images, size_t seed_frames, std::string* why) {
  if (so.mode != "auto") {
    *why = "sfm.mode " + so.mode;
    return so.mode;
  }
  if (images < static_cast<size_t>(so.auto_seeded_min_images)) {
    *why = "sfm.mode auto: " + std::to_string(images) + " images, fewer than sfm.auto_seeded_min_images (" +
           std::to_string(so.auto_seeded_min_images) + ")";
    return "incremental";
  }
  if (seed_frames < 2) {
    *why = "sfm.mode auto: " + std::to_string(images) + " images but " + std::to_string(seed_frames) +
           " frames with >= sfm.seed_min_corners board corners to seed the model";
    return "incremental";
  }
  *why = "sfm.mode auto: " + std::to_string(images) + " images (>= sfm.auto_seeded_min_images " +
         std::to_string(so.auto_seeded_min_images) + "), " + std::to_string(seed_frames) + " board-posed seeds";
  return "board_seeded";
}

nlohmann::json AddStructureFromMotion(const std::vector<CalibFrame>& frames, const std::string& workspace,
                                      const std::string& work_dir, const CalibOptions& options,
                                      BundleProblem* problem, std::map<std::string, double>* timings_s) {
  const SfmOptions& so = options.sfm;
  // Frames whose board pose rests on enough corners: board_seeded's seeds.
  std::vector<size_t> seeds;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (problem->frames[i].posed && static_cast<int>(frames[i].board.corner_ids.size()) >= so.seed_min_corners) {
      seeds.push_back(i);
    }
  }
  std::string mode_reason;
  const std::string mode = ResolveSfmMode(so, frames.size(), seeds.size(), &mode_reason);
  spdlog::info("sfm: {} ({})", mode, mode_reason);
  std::vector<SfmImage> images;
  std::map<std::string, int> frame_of;  // SfM name -> frame index
  for (size_t i = 0; i < frames.size(); ++i) {
    images.push_back({SfmName(frames[i].capture), frames[i].capture.device});
    frame_of[images.back().name] = static_cast<int>(i);
  }
  // Cross pairs: frames looking from similar directions (by their board
  // poses), the "loop closure" between sequences. Phone V frames pair with
  // phone L frames; geometry-pass frames with phone V and L frames (this ties
  // the pass to the V/L model) and with their own frames further apart in
  // time than the sequential matcher reaches (the pass is one closed turn).
  std::vector<std::pair<std::string, std::string>> pairs;
  const int overlap = mode == "board_seeded" ? so.seeded_overlap : so.sequential_overlap;
  const double max_angle = so.cross_pair_max_angle_deg * M_PI / 180.0;
  auto add_pairs = [&](size_t a, const std::function<bool(size_t)>& partner) {
    const Eigen::Vector3d da = problem->frames[a].cam_from_world.Inverse().translation.normalized();
    std::vector<std::pair<double, size_t>> candidates;
    for (size_t b = 0; b < frames.size(); ++b) {
      if (!problem->frames[b].posed || !partner(b)) continue;
      const Eigen::Vector3d db = problem->frames[b].cam_from_world.Inverse().translation.normalized();
      const double angle = std::acos(std::clamp(da.dot(db), -1.0, 1.0));
      if (angle <= max_angle) candidates.push_back({angle, b});
    }
    std::sort(candidates.begin(), candidates.end());
    for (size_t k = 0; k < candidates.size() && static_cast<int>(k) < so.cross_pairs_per_frame; ++k) {
      pairs.push_back({images[a].name, images[candidates[k].second].name});
    }
  };
  auto device_of = [&](size_t i) -> const std::string& { return frames[i].capture.device; };
  for (size_t a = 0; a < frames.size(); ++a) {
    if (!problem->frames[a].posed) continue;
    if (device_of(a) == "view") {
      add_pairs(a, [&](size_t b) { return device_of(b) == "light"; });
    } else if (device_of(a) == "geometry") {
      add_pairs(a, [&](size_t b) { return device_of(b) == "view" || device_of(b) == "light"; });
      add_pairs(a, [&](size_t b) {
        return device_of(b) == "geometry" && frames[b].capture.index > frames[a].capture.index + overlap;
      });
    }
  }
  // COLMAP extracts features per device with the device's fixed lens; the
  // geometry pass gets a camera of its own with phone V's parameters.
  std::map<std::string, Intrinsics> lenses = problem->devices;
  for (const CalibFrame& f : frames) {
    if (f.capture.device == "geometry") lenses["geometry"] = problem->devices.at(LensOf("geometry"));
  }
  SfmRunOptions run;
  run.colmap = so.colmap;
  run.image_dir = (fs::path(workspace) / "capture").string();
  run.work_dir = work_dir;
  run.sequential_overlap = overlap;
  run.ransac_trials = so.ransac_trials;
  run.matcher = so.matcher;
  run.verification = so.verification;
  run.threads = so.threads;
  run.min_registered = so.min_registered;
  run.max_features = so.max_features;
  run.first_octave = so.first_octave;
  run.mapper_global_ba_growth = so.mapper_global_ba_growth;
  run.mapper_global_ba_refinements = so.mapper_global_ba_refinements;
  run.reuse_dir = so.reuse_dir;
  if (mode == "board_seeded") {
    // The seeds keep their board pose; COLMAP places the rest.
    for (const size_t i : seeds) run.known_poses[images[i].name] = problem->frames[i].cam_from_world;
    RELIT_REQUIRE(run.known_poses.size() >= 2, "sfm.mode board_seeded: only ", run.known_poses.size(),
                  " frames show >= sfm.seed_min_corners = ", so.seed_min_corners, " board corners; lower it or "
                  "set sfm.mode: incremental in the --config file");
  }
  const SfmResult sfm = RunColmapSfm(images, lenses, pairs, run);
  for (const auto& [step, seconds] : sfm.timings_s) (*timings_s)["colmap_" + step] = seconds;
  if (so.matcher == "opencv") (*timings_s)["sfm_descriptor_matching"] = sfm.descriptor_matching_s;
  if (so.matcher == "opencv" && so.verification == "opencv") {
    (*timings_s)["sfm_pair_verification"] = sfm.pair_verification_s;
  }

  // Align the model to the board frame on camera centres.
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<int> index;
  for (const auto& [name, pose] : sfm.model.cam_from_model) {
    const int f = frame_of.at(name);
    if (!problem->frames[f].posed) continue;
    src.push_back(pose.Inverse().translation);
    dst.push_back(problem->frames[f].cam_from_world.Inverse().translation);
    index.push_back(f);
  }
  RobustFit fit;
  RELIT_REQUIRE(FitSimilarityRobust(src, dst, so.align_inlier_m, 500, &fit),
                "the COLMAP model (", sfm.model.cam_from_model.size(), " images) does not agree with the "
                "board poses: ", src.size(), " frames have both, fewer than 3 agree within sfm.align_inlier_m = ",
                so.align_inlier_m, " m. Check the board settings, or set sfm.enabled: false");
  spdlog::info("sfm: {} of {} images registered ({} models), aligned to the board on {} of {} frames "
               "(RMS {:.2f} mm, scale {:.4f} m per model unit)", sfm.model.cam_from_model.size(), images.size(),
               sfm.models, fit.inlier_count, src.size(), fit.rms_m * 1e3, fit.transform.scale);
  for (const std::string device : {"view", "light"}) {
    if (!sfm.registered_by_device.count(device)) {
      spdlog::warn("sfm: the largest COLMAP model holds no {} frame: the two phones' models do not "
                   "connect; {} frames keep their board poses only", device, device);
    }
  }
  if (lenses.count("geometry") && !sfm.registered_by_device.count("geometry")) {
    spdlog::warn("sfm: the largest COLMAP model holds no geometry-pass frame: they keep their board poses "
                 "(refined on the board corners); frames without a board pose stay unregistered");
  }
  int sfm_only = 0;
  for (const auto& [name, pose] : sfm.model.cam_from_model) {
    BundleFrame& frame = problem->frames[frame_of.at(name)];
    if (!frame.posed) {
      frame.cam_from_world = fit.transform.CamFromWorld(pose);
      frame.posed = true;
      ++sfm_only;
    }
  }
  std::vector<BundlePoint> tracks;
  for (size_t i = 0; i < sfm.model.points.size(); ++i) {
    BundlePoint point;
    point.position_m = fit.transform * sfm.model.points[i];
    for (const SfmTrackObservation& obs : sfm.model.tracks[i]) {
      point.observations.push_back({frame_of.at(obs.image), obs.pixel_px});
    }
    if (point.observations.size() >= 2) tracks.push_back(std::move(point));
  }
  const size_t points = tracks.size();
  std::vector<BundlePoint> dropped;
  problem->points = KeepLongestTracks(std::move(tracks), problem->frames.size(), so.points_per_frame, &dropped);
  for (const BundlePoint& point : dropped) problem->unrefined_points_m.push_back(point.position_m);
  size_t kept_observations = 0;
  for (const BundlePoint& point : problem->points) kept_observations += point.observations.size();
  if (so.points_per_frame > 0) {
    spdlog::info("sfm: the joint solve keeps {} of {} points ({} observations; sfm.points_per_frame {})",
                 problem->points.size(), points, kept_observations, so.points_per_frame);
  }
  nlohmann::json unregistered = nlohmann::json::object();
  for (const auto& [name, reason] : sfm.unregistered) unregistered[name] = reason;
  return {{"ran", true},
          {"mode", mode},
          {"mode_reason", mode_reason},
          {"seeded_frames", run.known_poses.size()},
          {"images", sfm.images},
          {"registered", sfm.model.cam_from_model.size()},
          {"registered_by_device", sfm.registered_by_device},
          {"models", sfm.models},
          {"model_sizes", sfm.model_sizes},
          {"verified_pairs", sfm.verified_pairs},
          {"cross_phone_pairs", pairs.size()},
          {"points", points},
          {"points_in_joint_solve", problem->points.size()},
          {"point_observations_in_joint_solve", kept_observations},
          {"frames_posed_by_sfm_only", sfm_only},
          {"alignment", {{"frames_with_both", src.size()},
                         {"inliers", fit.inlier_count},
                         {"rms_m", fit.rms_m},
                         {"scale_m_per_unit", fit.transform.scale}}},
          {"unregistered", unregistered},
          {"timings_s", sfm.timings_s},
          {"descriptor_matching_s", sfm.descriptor_matching_s},
          {"pair_verification_s", sfm.pair_verification_s}};
}

nlohmann::json CheckBoardScale(const std::vector<CalibFrame>& frames, const BundleProblem& problem,
                               const CalibOptions& options, double* measured_ratio) {
  const BoardSpec& spec = options.board;
  std::vector<double> ratios;
  for (size_t i = 0; i < frames.size(); ++i) {
    if (!problem.frames[i].posed) continue;
    const double r = MeasureMarkerRatio(frames[i].board, problem.devices.at(LensOf(frames[i].capture.device)), spec);
    if (r > 0) ratios.push_back(r);
  }
  const double specified = spec.marker_length_m / spec.square_length_m;
  const double measured = ratios.empty() ? 0.0 : Median(ratios);
  *measured_ratio = measured;
  nlohmann::json report = {{"frames", ratios.size()},
                           {"marker_to_square_measured", measured},
                           {"marker_to_square_specified", specified},
                           {"square_length_m_specified", spec.square_length_m},
                           {"square_length_m_measured_from_markers",
                            measured > 0 ? spec.marker_length_m / measured : 0.0},
                           {"note", "the images fix the board's shape, not its size: a board printed at the "
                                    "wrong scale with both lengths scaled alike cannot be detected"}};
  if (ratios.empty()) return report;
  const double error = measured / specified - 1;
  RELIT_REQUIRE(std::abs(error) <= options.refine.max_ratio_error,
                "board size mismatch: the printed markers measure ", measured,
                " of a square side, the config says marker_length_m / square_length_m = ",
                spec.marker_length_m, " / ", spec.square_length_m, " = ", specified, " (", error * 100,
                "% off, over ", ratios.size(), " frames). If marker_length_m is right, the squares are ",
                spec.marker_length_m / measured, " m: measure the printed board and fix board: in the --config file");
  return report;
}

nlohmann::json GeometryPassReport(const std::vector<CalibFrame>& frames, const BundleProblem& problem,
                                  const std::vector<bool>& posed_by_board, const BundleStats& stats,
                                  const nlohmann::json& sfm_report, int min_corners) {
  int count = 0, with_board = 0, board_posed = 0, registered = 0;
  double corner_sum = 0;
  int corner_frames = 0;
  nlohmann::json unregistered = nlohmann::json::array();
  for (size_t i = 0; i < frames.size(); ++i) {
    if (frames[i].capture.device != "geometry") continue;
    ++count;
    with_board += static_cast<int>(frames[i].board.corner_ids.size()) >= min_corners;
    board_posed += posed_by_board[i];
    if (problem.frames[i].posed) {
      ++registered;
    } else {
      unregistered.push_back(frames[i].capture.name);
    }
    if (problem.frames[i].posed && i < stats.frame_corner_rms_px.size() && stats.frame_corner_rms_px[i] > 0) {
      corner_sum += stats.frame_corner_rms_px[i] * stats.frame_corner_rms_px[i];
      ++corner_frames;
    }
  }
  int in_sfm = 0;
  if (sfm_report.contains("registered_by_device") && sfm_report["registered_by_device"].contains("geometry")) {
    in_sfm = sfm_report["registered_by_device"]["geometry"].get<int>();
  }
  return {{"frames", count},
          {"frames_with_board", with_board},
          {"posed_by_board", board_posed},
          {"registered_by_sfm", in_sfm},
          {"registered", registered},
          {"unregistered", unregistered},
          {"lens", "view (same phone)"},
          {"corner_rms_px", corner_frames > 0 ? std::sqrt(corner_sum / corner_frames) : 0.0}};
}

std::string UnregisteredReason(const CalibFrame& frame, bool posed_by_board, const nlohmann::json& sfm_report,
                               int min_corners, int board_markers) {
  const BoardObservation& board = frame.board;
  const int corners = static_cast<int>(board.corner_ids.size());
  const int markers = static_cast<int>(board.markers.size());
  std::string reason;
  if (markers == 0) {
    reason = "no board marker found (of " + std::to_string(board_markers) + ")";
  } else if (corners < std::max(4, min_corners)) {
    reason = std::to_string(markers) + " of " + std::to_string(board_markers) + " board markers, " +
             std::to_string(corners) + " ChArUco corners: fewer than detect.min_corners = " +
             std::to_string(min_corners) + " for a board pose";
  } else if (posed_by_board) {
    reason = "its board pose (" + std::to_string(corners) + " corners) lost every corner as an outlier "
             "(beyond refine.outlier_px) in the refinement";
  } else {
    reason = "no board pose from " + std::to_string(corners) + " corners (PnP failed or put the board behind "
             "the camera)";
  }
  if (!sfm_report.value("ran", false)) return reason + "; SfM off (sfm.enabled: false)";
  if (sfm_report.contains("unregistered") && sfm_report["unregistered"].contains(frame.capture.name)) {
    return reason + "; COLMAP: " + sfm_report["unregistered"][frame.capture.name].get<std::string>();
  }
  return reason + "; its COLMAP pose was dropped in the joint refinement (no inlier observation)";
}

}  // namespace relit::calib
