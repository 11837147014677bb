// What calib needs of the capture stage's capture/capture.json
// (relit.capture/1, read by core/capture_file.h): the kept frames of both
// phones with their times on the common clock and the paths of their
// images, checked for what calib relies on.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/capture_file.h"

namespace relit::calib {

using relit::CaptureFrame;

struct CaptureInput {
  std::vector<CaptureFrame> view;
  std::vector<CaptureFrame> light;
  // Geometry pass (ambient light, filmed with phone V: same lens); empty
  // when the capture has none. Its frames must be at phone V's image size.
  std::vector<CaptureFrame> geometry;
  int view_width_px = 0, view_height_px = 0;
  int light_width_px = 0, light_height_px = 0;
  double sync_offset_s = 0;
  // capture.json's inputs: "view", "light" and, with a geometry pass,
  // "geometry" (type "video" or "photos"); their display rotations.
  std::map<std::string, CaptureSource> sources;
};

// Reads W/capture/capture.json. Throws relit::Error naming the file for a
// missing file, another schema version or missing fields.
CaptureInput ReadCaptureFile(const std::string& workspace);

}  // namespace relit::calib
