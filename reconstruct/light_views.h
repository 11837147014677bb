// Phone L's frames as more views of the object for the photometric surface
// refinement. Phone L films with its flash on, so what it sees is lit from
// its own lens (no visible cast shadows) and from a path that wanders
// independently of phone V's: the views the phone V ring lacks. Calib
// registers them (cameras.json, device "light") but writes no undistorted
// copy, so they are undistorted here from capture's 8-bit images with the
// calibrated lens of device "light".
#pragma once

#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera.h"
#include "core/workspace.h"

namespace relit::reconstruct {

struct LightViews {
  std::vector<Camera> cameras;  // undistorted pinhole cameras (the lens without distortion)
  std::vector<cv::Mat> grays;   // CV_8U, the cameras' sizes
};

// Every registered phone L frame of `cameras` whose image capture.json lists
// (none without W/capture/capture.json, e.g. a workspace calibrated from
// COLMAP or a test fixture), at most `max_frames` of them evenly spaced
// (0 = all; proxy.max_frames, the phone V frames' cap). Throws
// relit::Error naming the file when an image cannot be read or its size is
// not the calibrated lens's.
LightViews LoadLightViews(const std::filesystem::path& workspace, const CamerasFile& cameras, int max_frames = 0);

}  // namespace relit::reconstruct
