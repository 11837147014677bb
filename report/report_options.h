// Options of relit-report. YAML (--config): the `report:` section of
// pipeline.yaml as its own file; unknown keys are errors. The field tables
// (report_options.cc) read it and generate docs/report.md's table.
#pragma once

#include <string>

#include "core/option_fields.h"
#include "report/coverage.h"

namespace relit::report {

struct MeshPreviewOptions {
  int size_px = 320;            // square previews
  int views = 3;                // azimuths spread evenly around the object
  double elevation_deg = 30;    // above the board plane
  int samples_per_pixel = 8;    // path tracer samples (direct light only)

  static const OptionFields<MeshPreviewOptions>& Fields();
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

  static const OptionFields<ReportOptions>& Fields();
  void Check() const;  // the workspace is given; ranges: CheckOptions
};

}  // namespace relit::report
