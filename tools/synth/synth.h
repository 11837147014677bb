// relit-synth: renders a synthetic dual-phone capture with ground truth.
// See docs/synthetic.md.
#pragma once

#include <string>

#include "core/image.h"
#include "tools/synth/capture_plan.h"
#include "tools/synth/ffmpeg_io.h"
#include "tools/synth/synth_options.h"

namespace relit::synth {

struct SynthSummary {
  std::string out_dir;
  double light_start_offset_s = 0;
  int frames_rendered = 0;  // video frames over all videos
  int eval_images = 0;
  double seconds = 0;
};

// Renders everything described by `options` into options.out (atomically:
// the directory appears complete or not at all). Throws relit::Error.
SynthSummary RunSynthImpl(const SynthOptions& options);

// Records the shared room sound (noise and claps on the common clock) as
// each phone hears it, over its own recording interval and at its own
// sample rate: <out_dir>/truth/audio/{view,light[,geometry]}.wav, the tracks
// the videos are muxed with. Also used by relit-bench-cycles-capture.
void WriteCaptureAudio(const SynthOptions& options, const CapturePlan& plan, const std::string& out_dir);

// The encoder settings of one phone's MP4 in <out_dir>: its plan's size,
// frame rate, audio rate and start, rotation metadata and the audio track
// WriteCaptureAudio wrote. Also used by relit-bench-cycles-capture.
VideoEncodeParams VideoEncodeParamsFor(const VideoPlan& video, int crf, const std::string& out_dir);

// The image as a phone shows it: turned clockwise by its display rotation
// (0, 90, 180, 270), as players apply the rotation of the videos. Board-clip
// PNGs are written this way.
Image RotatedForDisplay(const Image& image, int rotation_deg);

// Command line: parses flags and an optional --config YAML, then calls
// RunSynthImpl. Returns the process exit code; errors propagate as relit::Error.
int RunSynth(int argc, char** argv);

}  // namespace relit::synth
