// Options of relit-report. YAML (--config): the `report:` section of
// pipeline.yaml as its own file; unknown keys are errors.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "report/coverage.h"

namespace relit {
class OptionsReader;
}

namespace relit::report {

struct MeshPreviewOptions {
  int size_px = 320;            // square previews
  int views = 3;                // azimuths spread evenly around the object
  double elevation_deg = 30;    // above the board plane
  int samples_per_pixel = 8;    // path tracer samples (direct light only)

  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

struct ReportOptions {
  std::string workspace;           // W: reads the stages' folders, writes W/report
  std::string log_level = "info";
  // --force: replace an output folder that relit did not write (never one
  // holding an input, never a file). Not an option of the config file.
  bool force = false;
  int thumbnail_width_px = 240;    // frames, trimaps, mattes, turntable strips
  int sample_frames = 4;           // frames shown with their trimap and matte
  int strip_frames = 8;            // turntable frames shown per strip
  MeshPreviewOptions mesh_preview;
  CoverageThresholds coverage;

  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

}  // namespace relit::report
