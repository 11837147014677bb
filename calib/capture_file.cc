#include "calib/capture_file.h"

#include <filesystem>

#include "core/error.h"

namespace relit::calib {

namespace {

namespace fs = std::filesystem;

// The geometry pass shares phone V's lens, so it must share its pixel grid.
void RequireViewSize(const CaptureFile& file, const CaptureInput& input, const std::string& path) {
  const CaptureSource& source = file.inputs.at("geometry");
  for (size_t i = 0; i < file.geometry.size(); ++i) {
    const CaptureFrame& frame = file.geometry[i];
    const bool photos = source.type == "photos";
    const int width = photos ? frame.width_px : source.output_width_px;
    const int height = photos ? frame.height_px : source.output_height_px;
    RELIT_REQUIRE(width == input.view_width_px && height == input.view_height_px, path, ": geometry-pass frame ",
                  i, " is ", width, "x", height, " but phone V's frames are ", input.view_width_px, "x",
                  input.view_height_px, ". The geometry pass is calibrated with phone V's lens: film it with "
                  "phone V at the same video resolution (or rerun relit-capture without --geometry)");
  }
}

}  // namespace

CaptureInput ReadCaptureFile(const std::string& workspace) {
  const std::string path = CaptureFilePath(workspace);
  RELIT_REQUIRE(fs::exists(path), "no capture stage output: ", path,
                " does not exist; run relit-capture --out ", (fs::path(workspace) / "capture").string(),
                " first");
  const CaptureFile file = relit::ReadCaptureFile(path);
  CaptureInput input;
  input.view = file.view;
  input.light = file.light;
  input.geometry = file.geometry;
  RELIT_REQUIRE(!input.view.empty(), path, " lists no phone V frames: rerun relit-capture");
  RELIT_REQUIRE(!input.light.empty(), path, " lists no phone L frames: rerun relit-capture");
  input.view_width_px = file.inputs.at("view").output_width_px;
  input.view_height_px = file.inputs.at("view").output_height_px;
  input.light_width_px = file.inputs.at("light").output_width_px;
  input.light_height_px = file.inputs.at("light").output_height_px;
  input.sync_offset_s = file.sync_offset_s;
  input.sources = file.inputs;
  for (const CaptureFrame& frame : input.view) {
    RELIT_REQUIRE(!frame.linear.empty(), path, ": phone V frame ", frame.name,
                  " has no linear EXR ('linear'): rerun relit-capture");
  }
  if (!input.geometry.empty()) RequireViewSize(file, input, path);
  return input;
}

}  // namespace relit::calib
