// For the calib tests: the tiny synthetic capture they calibrate, rendered
// by relit-synth and ingested by relit-capture as a real one would be.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include "capture/capture.h"
#include "core/options.h"
#include "tools/synth/synth.h"

namespace relit::calib::testing {

// relit-synth's render of `config` (a tiny-size YAML) into `synth_dir`; when
// the environment variable `reuse_variable` is set, the render in the folder
// it names instead (a CTest fixture renders it once per run). Returns the
// folder that holds the render.
inline std::filesystem::path RenderSynthUnlessReused(const char* reuse_variable, const std::string& config,
                                                     const std::filesystem::path& synth_dir) {
  if (const char* reuse = std::getenv(reuse_variable)) return reuse;
  synth::SynthOptions o = synth::SynthOptions::ForSize("tiny");
  OptionsReader reader = OptionsReader::FromFile(config);
  ReadOptions(reader, &o);
  o.out = synth_dir.string();
  synth::RunSynthImpl(o);
  return synth_dir;
}

// relit-capture's options for a synthetic render's two videos, keeping
// every usable phone V frame; the capture folder is `out`.
inline capture::CaptureOptions SynthCaptureOptions(const std::filesystem::path& synth_dir, const std::string& out) {
  capture::CaptureOptions c;
  c.view = (synth_dir / "view.mp4").string();
  c.light = (synth_dir / "light.mp4").string();
  c.out = out;
  c.view_select.target_frames = 1000;
  return c;
}

}  // namespace relit::calib::testing
