// relit-calib: the calib stage. Reads the workspace's capture/ folder
// (capture.json of relit-capture), detects the ChArUco board in every frame
// of both phones, calibrates both lenses, registers every frame (board PnP
// and COLMAP structure from motion, aligned to the board and refined jointly
// with Ceres), places phone L's flash for every phone V frame and writes
// W/calib/: cameras.json, lights.json, undistorted phone V frames, a COLMAP
// text model, calib_report.json, calib.log and run.json. See docs/calib.md.
#pragma once

#include <map>
#include <string>

#include "calib/calib_options.h"

namespace relit::calib {

struct CalibSummary {
  std::string out_dir;
  std::map<std::string, int> frames;       // per device, in capture.json
  std::map<std::string, int> registered;   // per device, with a pose
  double corner_rms_px = 0;
  double point_rms_px = 0;
  int sfm_registered = 0;
  int lights = 0;
  int unreliable_lights = 0;
  double marker_ratio_measured = 0;        // marker / square side, measured
  double seconds = 0;
};

// Runs the stage with checked options; W/calib appears complete or not at
// all. Throws relit::Error with a one-line message on bad input.
CalibSummary RunCalibImpl(const CalibOptions& options);

// Command line: --workspace W [--config calib.yaml] and a few overrides,
// then RunCalibImpl.
int RunCalib(int argc, char** argv);

}  // namespace relit::calib
