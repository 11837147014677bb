// Accuracy of a calib/ folder against a synthetic capture's truth.json
// (relit-synth): camera poses per device, lens focal lengths, flash
// positions. Shared by calib_synth_test and the calib benchmark; it reads
// only files (capture.json, cameras.json, lights.json, truth.json).
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/board.h"
#include "core/camera.h"
#include "core/capture_file.h"

namespace relit::calib {

struct DeviceAccuracy {
  int frames = 0;                    // calibrated frames compared with truth
  double position_median_mm = 0;     // camera centre error
  double position_p90_mm = 0;
  double rotation_median_deg = 0;
  double rotation_p90_deg = 0;
  double focal_error = 0;            // calibrated fx / true fx - 1 (0 when the lens is not in truth)
};

struct CalibAccuracy {
  std::map<std::string, DeviceAccuracy> devices;  // "view", "light", "geometry" when present
  int flashes = 0;                   // reliable lights.json frames
  double flash_median_mm = 0;
  double flash_p90_mm = 0;

  nlohmann::json ToJson() const;
  std::string Summary() const;       // one line for logs and test output
};

// `workspace` holds capture/ and calib/; `truth` is the parsed truth.json
// of the synthetic capture capture/ was made from. Frames are matched
// through capture.json's source_frame indices.
CalibAccuracy MeasureCalibAccuracy(const std::string& workspace, const nlohmann::json& truth);

// relit-synth's truth is for a video's stored pixels; relit-capture hands
// calib the frames turned clockwise by their display rotation (0/90/180/
// 270). These give the truth's lens, pose and camera-frame point as calib
// sees them: the camera frame turned about its optical axis.
Intrinsics DisplayedIntrinsics(const Intrinsics& stored, int rotation_deg);
Rigid3 DisplayedCamFromWorld(const Rigid3& stored_cam_from_world, int rotation_deg);
Eigen::Vector3d DisplayedCameraPoint(const Eigen::Vector3d& stored_cam, int rotation_deg);
// A phone's rotation in truth.json (its video's display_rotation_deg, 0 when absent).
int TruthDisplayRotation(const nlohmann::json& truth, const std::string& phone);
// truth.json's lens of `phone` and the flash offset (phone L's camera frame), as calib sees them.
Intrinsics TruthLens(const nlohmann::json& truth, const std::string& phone);
std::vector<double> TruthFlashOffset(const nlohmann::json& truth);

// truth.json's frame of a kept capture frame (`device`'s video, through the
// frame's source_frame index). `capture_path` names capture.json in errors.
const nlohmann::json& TruthFrameOf(const CaptureFile& capture, const std::string& capture_path,
                                   const nlohmann::json& truth, const std::string& device, const std::string& name);

// A truth alpha matte (stored pixels, relit-synth's truth/view_alpha) as calib
// sees its frame: one channel, turned clockwise by the display rotation and
// resized to width x height when capture downscaled the video. Still
// distorted: resample it as the frame was (FrameUndistorter::Remap).
cv::Mat DisplayedTruthAlpha(const std::string& path, int rotation_deg, int width, int height);

// The board truth.json says was rendered (its "board" object).
BoardSpec BoardSpecFromTruth(const nlohmann::json& truth);

double Median(std::vector<double> values);
// Value at fraction q in [0, 1] of the sorted values (nearest rank).
double Quantile(std::vector<double> values, double q);

}  // namespace relit::calib
