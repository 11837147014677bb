#include "calib/truth_accuracy.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "core/camera.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/workspace.h"

namespace relit::calib {

using nlohmann::json;

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const size_t index = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  return values[index];
}

double Median(std::vector<double> values) { return Quantile(std::move(values), 0.5); }

namespace {

// Camera frame of the displayed image from the stored one: a turn of
// rotation_deg about +z (90: displayed x = -stored y, displayed y = stored x).
Eigen::Matrix3d DisplayTurn(int rotation_deg) {
  RELIT_REQUIRE(rotation_deg == 0 || rotation_deg == 90 || rotation_deg == 180 || rotation_deg == 270,
                "display rotation must be 0, 90, 180 or 270 degrees, got ", rotation_deg);
  const double a = rotation_deg * M_PI / 180;
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r(0, 0) = std::round(std::cos(a));
  r(0, 1) = -std::round(std::sin(a));
  r(1, 0) = std::round(std::sin(a));
  r(1, 1) = std::round(std::cos(a));
  return r;
}

}  // namespace

Eigen::Vector3d DisplayedCameraPoint(const Eigen::Vector3d& stored_cam, int rotation_deg) {
  return DisplayTurn(rotation_deg) * stored_cam;
}

Rigid3 DisplayedCamFromWorld(const Rigid3& stored, int rotation_deg) {
  return Rigid3(DisplayTurn(rotation_deg), Eigen::Vector3d::Zero()) * stored;
}

Intrinsics DisplayedIntrinsics(const Intrinsics& stored, int rotation_deg) {
  DisplayTurn(rotation_deg);  // checks the angle
  Intrinsics k = stored;
  for (int turn = 0; turn < rotation_deg / 90; ++turn) {
    // One clockwise quarter turn: displayed (x, y) = (h - 1 - y, x); the
    // tangential terms follow the normalised coordinates (x', y') = (-y, x).
    const Intrinsics before = k;
    k.width = before.height;
    k.height = before.width;
    k.fx = before.fy;
    k.fy = before.fx;
    k.cx = before.height - 1 - before.cy;
    k.cy = before.cx;
    k.distortion.p1 = before.distortion.p2;
    k.distortion.p2 = -before.distortion.p1;
  }
  return k;
}

int TruthDisplayRotation(const json& truth, const std::string& phone) {
  if (!truth.contains("videos") || !truth["videos"].contains(phone)) return 0;
  return truth["videos"][phone].value("display_rotation_deg", 0);
}

Intrinsics TruthLens(const json& truth, const std::string& phone) {
  return DisplayedIntrinsics(IntrinsicsFromJson(truth.at("phones").at(phone).at("intrinsics")),
                             TruthDisplayRotation(truth, phone));
}

std::vector<double> TruthFlashOffset(const json& truth) {
  const Eigen::Vector3d offset = DisplayedCameraPoint(Vector3FromJson(truth.at("flash").at("offset_cam_m")),
                                                      TruthDisplayRotation(truth, "light"));
  return {offset.x(), offset.y(), offset.z()};
}

BoardSpec BoardSpecFromTruth(const json& truth) {
  const json& b = truth.at("board");
  BoardSpec spec;
  spec.squares_x = b.at("squares_x");
  spec.squares_y = b.at("squares_y");
  spec.square_length_m = b.at("square_length_m");
  spec.marker_length_m = b.at("marker_length_m");
  spec.dictionary = b.at("dictionary");
  CheckOptions(spec);
  return spec;
}

const json& TruthFrameOf(const CaptureFile& capture, const std::string& capture_path, const json& truth,
                         const std::string& device, const std::string& name) {
  const CaptureFrame* frame = capture.Find(name);
  RELIT_REQUIRE(frame != nullptr && frame->source_frame >= 0, "frame ", name, " is not in ", capture_path,
                " with its video frame: was calib run on this capture?");
  RELIT_REQUIRE(truth.contains("videos") && truth["videos"].contains(device), "truth.json has no video '", device,
                "'");
  return truth["videos"][device]["frames"].at(frame->source_frame);
}

cv::Mat DisplayedTruthAlpha(const std::string& path, int rotation_deg, int width, int height) {
  cv::Mat alpha = ReadImage(path).ToMat();
  if (alpha.channels() > 1) cv::extractChannel(alpha, alpha, 0);
  if (rotation_deg == 90) cv::rotate(alpha, alpha, cv::ROTATE_90_CLOCKWISE);
  if (rotation_deg == 180) cv::rotate(alpha, alpha, cv::ROTATE_180);
  if (rotation_deg == 270) cv::rotate(alpha, alpha, cv::ROTATE_90_COUNTERCLOCKWISE);
  if (alpha.cols != width || alpha.rows != height) {  // capture downscaled the video
    cv::resize(alpha, alpha, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  }
  return alpha;
}

CalibAccuracy MeasureCalibAccuracy(const std::string& workspace, const json& truth) {
  const CaptureFile capture = ReadCaptureFile(CaptureFilePath(workspace));
  const CamerasFile cameras = ReadCamerasFile(workspace + "/calib/cameras.json");
  const LightsFile lights = ReadLightsFile(workspace + "/calib/lights.json");

  const std::string capture_path = CaptureFilePath(workspace);
  auto truth_frame = [&](const std::string& device, const std::string& name) -> const json& {
    return TruthFrameOf(capture, capture_path, truth, device, name);
  };

  std::map<std::string, std::vector<double>> position_mm, rotation_deg;
  for (const CalibratedFrame& f : cameras.frames) {
    const std::string phone = f.device == "geometry" ? "view" : f.device;
    const Rigid3 truth_pose = DisplayedCamFromWorld(Rigid3FromJson(truth_frame(f.device, f.name)["cam_from_world"]),
                                                    TruthDisplayRotation(truth, f.device == "geometry" ? "geometry" : phone));
    position_mm[f.device].push_back(
        (f.cam_from_world.Inverse().translation - truth_pose.Inverse().translation).norm() * 1e3);
    rotation_deg[f.device].push_back(RotationAngle(f.cam_from_world.rotation, truth_pose.rotation) * 180 / M_PI);
  }
  CalibAccuracy accuracy;
  for (const auto& [device, errors] : position_mm) {
    DeviceAccuracy& d = accuracy.devices[device];
    d.frames = static_cast<int>(errors.size());
    d.position_median_mm = Median(errors);
    d.position_p90_mm = Quantile(errors, 0.9);
    d.rotation_median_deg = Median(rotation_deg[device]);
    d.rotation_p90_deg = Quantile(rotation_deg[device], 0.9);
    // The geometry pass is filmed by phone V: its lens is phone V's.
    const std::string phone = device == "geometry" ? "view" : device;
    const auto lens = cameras.devices.find(device);
    if (lens != cameras.devices.end() && truth["phones"].contains(phone)) {
      d.focal_error = lens->second.fx / TruthLens(truth, phone).fx - 1;
    }
  }
  std::vector<double> flash_mm;
  for (const FrameLight& l : lights.frames) {
    if (!l.reliable) continue;
    const json& t = truth_frame("view", l.view_frame);
    flash_mm.push_back((l.position_m - Vector3FromJson(t["light_position_world_m"])).norm() * 1e3);
  }
  accuracy.flashes = static_cast<int>(flash_mm.size());
  accuracy.flash_median_mm = Median(flash_mm);
  accuracy.flash_p90_mm = Quantile(flash_mm, 0.9);
  return accuracy;
}

json CalibAccuracy::ToJson() const {
  json out = json::object();
  for (const auto& [device, d] : devices) {
    out["devices"][device] = {{"frames", d.frames},
                              {"position_median_mm", d.position_median_mm},
                              {"position_p90_mm", d.position_p90_mm},
                              {"rotation_median_deg", d.rotation_median_deg},
                              {"rotation_p90_deg", d.rotation_p90_deg},
                              {"focal_error", d.focal_error}};
  }
  out["flash"] = {{"frames", flashes}, {"median_mm", flash_median_mm}, {"p90_mm", flash_p90_mm}};
  return out;
}

std::string CalibAccuracy::Summary() const {
  std::ostringstream s;
  s.precision(3);
  for (const auto& [device, d] : devices) {
    s << device << ": " << d.frames << " frames, median " << d.position_median_mm << " mm / "
      << d.rotation_median_deg << " deg (p90 " << d.position_p90_mm << " mm / " << d.rotation_p90_deg
      << " deg), focal error " << d.focal_error * 100 << "%; ";
  }
  s << "flash: " << flashes << " frames, median " << flash_median_mm << " mm (p90 " << flash_p90_mm << " mm)";
  return s.str();
}

}  // namespace relit::calib
