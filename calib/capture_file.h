// A small reader of the capture stage's capture/capture.json
// (relit.capture/1): the kept frames of both phones with their times on the
// common clock and the paths of their images. Only the fields calib needs.
#pragma once

#include <string>
#include <vector>

namespace relit::calib {

struct CaptureFrame {
  std::string device;        // "view", "light" or "geometry" (the optional geometry pass)
  int index = 0;             // position in the capture's list (file NNNNNN)
  std::string name;          // "<device>/NNNNNN": lexical order = time per device
  double time_s = 0;         // common clock (phone V's); geometry pass: its own clock (photos: index)
  int source_frame = -1;     // frame index in the original video
  std::string image;         // 8-bit sRGB copy, path relative to the workspace
  std::string linear;        // linear half EXR (phone V only), relative to the workspace
};

struct CaptureInput {
  std::vector<CaptureFrame> view;
  std::vector<CaptureFrame> light;
  // Geometry pass (ambient light, filmed with phone V: same lens); empty
  // when the capture has none. Its frames must be at phone V's image size.
  std::vector<CaptureFrame> geometry;
  int view_width_px = 0, view_height_px = 0;
  int light_width_px = 0, light_height_px = 0;
  double sync_offset_s = 0;
};

// Reads W/capture/capture.json. Throws relit::Error naming the file for a
// missing file, another schema version or missing fields.
CaptureInput ReadCaptureFile(const std::string& workspace);

}  // namespace relit::calib
