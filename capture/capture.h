// relit-capture: ingests the two phone videos (and optionally a geometry
// pass), puts them on one clock by audio cross-correlation, selects and
// linearises frames and writes the workspace folder capture/ with
// capture.json (schema relit.capture/1). See docs/capture.md and
// docs/formats.md.
#pragma once

#include <string>

#include "capture/capture_options.h"

namespace relit::capture {

constexpr const char* kCaptureKind = "capture";
constexpr int kCaptureVersion = 1;

struct CaptureSummary {
  std::string out_dir;
  std::string sync_method;
  double offset_s = 0;
  double confidence = 0;
  int view_frames_decoded = 0;
  int view_frames_kept = 0;
  int light_frames_kept = 0;
  int geometry_frames_kept = 0;
  double seconds = 0;
};

// Runs the stage with checked options; the output folder appears complete or
// not at all. Throws relit::Error with a one-line message on bad input.
CaptureSummary RunCaptureImpl(const CaptureOptions& options);

// Command line: flags and an optional --config YAML, then RunCaptureImpl.
int RunCapture(int argc, char** argv);

}  // namespace relit::capture
