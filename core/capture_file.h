// capture/capture.json (relit.capture/1), as read by every later stage and
// tool: the kept frames of both phones (and of an optional geometry pass)
// with their times on the common clock and their image paths, the rejected
// phone V frames, the output image sizes, the sync result and the frame
// counts. docs/formats.md describes every field.
//
// There is one writer, relit-capture (capture/capture.cc): most of the file
// is its own diagnostics (probe results, scores, options), which no reader
// needs as typed fields.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace relit {

struct CaptureFrame {
  std::string device;     // "view", "light" or "geometry" (the optional geometry pass)
  int index = 0;          // position in the capture's list (file NNNNNN)
  std::string name;       // "<device>/NNNNNN": lexical order = time per device
  double time_s = 0;      // common clock (phone V's); geometry pass: its own clock (photos: index)
  int source_frame = -1;  // frame index in the original video (-1: not recorded)
  std::string image;      // 8-bit sRGB copy, path relative to the workspace
  std::string linear;     // linear half EXR (phone V only), relative to the workspace
  double sharpness = 0;   // variance of the Laplacian of luma (NaN: not recorded)
  // The frame's own image size where the file records one (geometry-pass
  // photos); 0 otherwise: the size of its input applies.
  int width_px = 0, height_px = 0;
};

// A phone V frame relit-capture decoded and did not keep.
struct RejectedFrame {
  double time_s = 0;     // common clock (NaN: not recorded)
  double sharpness = 0;  // NaN: not recorded
  std::string reason;    // duplicate, dark, clipped, blurred, outside_light_video, not_selected ("?": none)
};

// One entry of `inputs`: what the later stages need of a video (or of the
// geometry pass's photo folder).
struct CaptureSource {
  std::string type;                // "video" or "photos" (geometry pass); "" for the phones
  int output_width_px = 0;         // size of the written frames (0 for photos: per frame)
  int output_height_px = 0;
  std::string transfer_used;       // how phone V's video was linearised: srgb, gamma2.2, hlg, pq
  // Clockwise display rotation the written frames were turned by (0, 90,
  // 180, 270): the sensor's rows, read out in time order, run along the
  // written frames' columns at 90 and 270.
  int rotation_deg = 0;
};

struct CaptureFile {
  static constexpr const char* kKind = "capture";
  static constexpr int kVersion = 1;
  // Kept frames, in index order (= time order per device).
  std::vector<CaptureFrame> view, light, geometry;
  std::vector<RejectedFrame> rejected_view;
  std::map<std::string, CaptureSource> inputs;  // "view", "light" and, with a geometry pass, "geometry"
  double sync_offset_s = 0;                     // t_view = t_light + offset
  nlohmann::json sync;                          // the whole sync record (method, confidence, drift, ...)
  std::map<std::string, int> view_counts;       // decoded phone V frames per reason, and "kept"
  std::optional<int> light_usable, light_kept;  // phone L frame counts (absent in minimal files)

  // The kept frame called `name` ("view/000012"), or null.
  const CaptureFrame* Find(const std::string& name) const;
};

// W/capture/capture.json.
std::string CaptureFilePath(const std::string& workspace);

// Reads and checks a capture.json: the kept frames (index, time in order,
// image), the phones' output sizes and the sync offset are required; the
// rest is read when present. Throws relit::Error naming the file and field.
CaptureFile ReadCaptureFile(const std::string& path);

}  // namespace relit
