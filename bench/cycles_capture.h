// A dual-phone capture rendered by Blender Cycles instead of relit's path
// tracer (issue 25 item 3): the same capture-folder format as relit-synth
// (view.mp4, light.mp4, truth.json, truth/, eval/, run.json), so the
// pipeline's own truth scorers read it.
//
// What comes from relit-synth: the plan (MakeCapturePlan: lenses, hand-held
// paths, flash positions, clock offset, claps, eval views and lights), the
// room sound, the sensor model and the encoder. What does not: every pixel.
// The scene is the Stanford bunny and a glossy sphere painted procedurally
// in Blender (bench/cycles_capture.py), on the board and a wooden table;
// Cycles renders pinhole frames on a canvas large enough for the lens, and
// the lens distortion is applied here by resampling (Blender has no OpenCV
// lens model). The eval images, their noise twins and alpha mattes are
// Cycles renders too.
//
// Layout of the output folder:
//   render/scene/      world-frame meshes, board texture and envmaps Blender reads
//   render/videos-<hash>/, render/eval-<hash>/
//                      Cycles EXRs, one per job, kept between runs (the cache:
//                      each <hash> covers its jobs, the scene files and the
//                      script, so a new eval set keeps the video frames);
//                      render/spec.json and render/blender.log: the last run
//   capture/           the capture folder, rebuilt only when a hash or the
//                      sensor/encoding options change
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "tools/synth/synth_options.h"

namespace relit::bench {

struct CyclesCaptureOptions {
  synth::SynthOptions synth;   // plan, lenses, sensor, audio; preset must be "bunny"
  std::string out_dir;         // see the layout above
  std::string blender = "blender";
  std::string script;          // bench/cycles_capture.py
  int threads = 2;             // Cycles CPU threads
  double sphere_radius_m = 0.022;
};

struct CyclesCaptureSummary {
  std::string capture_dir;
  std::string spec_hash;
  bool capture_reused = false;  // capture/ was already built from this spec
  int jobs = 0, jobs_rendered = 0;
  double render_s = 0;          // Blender wall time of this run (0 when cached)
  double video_frame_s = 0;     // mean Cycles seconds per video frame rendered (this run)
  double eval_image_s = 0;      // mean Cycles seconds per eval image rendered (this run)
  double assemble_s = 0;        // distortion, sensor, encoding, truth.json
  nlohmann::json ToJson() const;
};

// Renders what is missing and assembles capture/. Throws relit::Error with a
// one-line message (Blender missing or failing, a job's EXR absent, options
// the Cycles scene cannot reproduce: rolling shutter, flash shadow mask,
// geometry pass, board clips).
CyclesCaptureSummary MakeCyclesCapture(const CyclesCaptureOptions& options);

// The bunny-plus-sphere scene's Blender material of each foreground object,
// as written to truth.json ("material").
nlohmann::json CyclesMaterials();

}  // namespace relit::bench
