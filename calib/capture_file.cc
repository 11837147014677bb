#include "calib/capture_file.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "core/error.h"
#include "core/json_file.h"

namespace relit::calib {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kCaptureKind = "capture";
constexpr int kCaptureVersion = 1;

std::vector<CaptureFrame> ReadFrames(const json& capture, const std::string& key,
                                     const std::string& device, const std::string& path) {
  // Geometry-pass photos carry no time: their file order is their order.
  const bool untimed = device == "geometry";
  const json& frames = JsonField(capture, key, path);
  RELIT_REQUIRE(frames.is_array(), path, ": '", key, "' must be a list");
  std::vector<CaptureFrame> result;
  for (size_t i = 0; i < frames.size(); ++i) {
    const std::string where = path + ": " + key + "[" + std::to_string(i) + "]";
    CaptureFrame frame;
    frame.device = device;
    frame.index = JsonInt(frames[i], "index", where);
    char name[64];
    std::snprintf(name, sizeof(name), "%s/%06d", device.c_str(), frame.index);
    frame.name = name;
    frame.time_s = untimed && !frames[i].contains("time_s") ? frame.index : JsonNumber(frames[i], "time_s", where);
    frame.source_frame = frames[i].value("source_frame", -1);
    frame.image = "capture/" + JsonString(frames[i], "image", where);
    if (frames[i].contains("linear")) frame.linear = "capture/" + JsonString(frames[i], "linear", where);
    result.push_back(frame);
  }
  std::sort(result.begin(), result.end(),
            [](const CaptureFrame& a, const CaptureFrame& b) { return a.index < b.index; });
  for (size_t i = 1; i < result.size(); ++i) {
    RELIT_REQUIRE(result[i].time_s > result[i - 1].time_s, path, ": ", key,
                  " are not in time order (", result[i - 1].name, " at ", result[i - 1].time_s,
                  " s, ", result[i].name, " at ", result[i].time_s,
                  " s): rerun relit-capture");
  }
  return result;
}

void ReadSize(const json& capture, const std::string& device, const std::string& path, int* width,
              int* height) {
  const std::string where = path + ": inputs." + device;
  const json& input = JsonField(JsonField(capture, "inputs", path), device, path + ": inputs");
  *width = JsonInt(input, "output_width_px", where);
  *height = JsonInt(input, "output_height_px", where);
  RELIT_REQUIRE(*width > 0 && *height > 0, where, ": image size must be positive");
}

}  // namespace

CaptureInput ReadCaptureFile(const std::string& workspace) {
  const std::string path = (fs::path(workspace) / "capture" / "capture.json").string();
  RELIT_REQUIRE(fs::exists(path), "no capture stage output: ", path,
                " does not exist; run relit-capture --out ", (fs::path(workspace) / "capture").string(),
                " first");
  const json capture = ReadJsonFile(path, kCaptureKind, kCaptureVersion);
  CaptureInput input;
  input.view = ReadFrames(capture, "view_frames", "view", path);
  input.light = ReadFrames(capture, "light_frames", "light", path);
  RELIT_REQUIRE(!input.view.empty(), path, " lists no phone V frames: rerun relit-capture");
  RELIT_REQUIRE(!input.light.empty(), path, " lists no phone L frames: rerun relit-capture");
  ReadSize(capture, "view", path, &input.view_width_px, &input.view_height_px);
  ReadSize(capture, "light", path, &input.light_width_px, &input.light_height_px);
  if (capture.contains("sync") && capture["sync"].contains("offset_s")) {
    input.sync_offset_s = capture["sync"]["offset_s"].get<double>();
  }
  for (const CaptureFrame& frame : input.view) {
    RELIT_REQUIRE(!frame.linear.empty(), path, ": phone V frame ", frame.name,
                  " has no linear EXR ('linear'): rerun relit-capture");
  }
  if (capture.contains("geometry_frames") && !capture["geometry_frames"].empty()) {
    input.geometry = ReadFrames(capture, "geometry_frames", "geometry", path);
    // The geometry pass shares phone V's lens, so it must share its pixel grid.
    const json& source = JsonField(JsonField(capture, "inputs", path), "geometry", path + ": inputs");
    const json& frames = capture["geometry_frames"];
    for (size_t i = 0; i < frames.size(); ++i) {
      const json& sized = source.value("type", "") == "photos" ? frames[i] : source;
      const char* width_key = sized.contains("output_width_px") ? "output_width_px" : "width_px";
      const char* height_key = sized.contains("output_height_px") ? "output_height_px" : "height_px";
      const int width = JsonInt(sized, width_key, path + ": geometry_frames[" + std::to_string(i) + "]");
      const int height = JsonInt(sized, height_key, path + ": geometry_frames[" + std::to_string(i) + "]");
      RELIT_REQUIRE(width == input.view_width_px && height == input.view_height_px, path, ": geometry-pass frame ",
                    i, " is ", width, "x", height, " but phone V's frames are ", input.view_width_px, "x",
                    input.view_height_px, ". The geometry pass is calibrated with phone V's lens: film it with "
                    "phone V at the same video resolution (or rerun relit-capture without --geometry)");
    }
  }
  return input;
}

}  // namespace relit::calib
