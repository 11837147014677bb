// Options of the relight stage's steps that need no LibTorch: radiance cues,
// the frame split (dataset), and the views `render` produces. The network
// and optimiser options (ModelOptions, TrainOptions) live in model.h; the
// whole `relight:` section is assembled in relight_options.h. Defaults live
// here, keys, ranges and docs in the field tables (stage_options.cc), from
// which docs/relight.md's tables are generated (tools/options_doc).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/option_fields.h"
#include "relight/cue_frames.h"

namespace relit::relight {

struct CueStageOptions {
  int samples_per_pixel = 16;   // per cue frame; the 5 bases share every path
  int max_depth = 4;            // bounces (global illumination); 1 = direct light only
  // Filter the bounce light's path-tracing noise (the flash's direct light
  // is exact and stays apart), as render.denoise_cues does for new lights.
  // A least-squares fit on noisy cues shrinks their weights: on the `full`
  // spot with true inputs the filtered 16-spp cues fit 0.7 dB better than
  // raw ones, and better than raw 64-spp ones (docs/relight.md).
  bool denoise = true;
  uint64_t seed = 1;
  // Intensity (W/sr) of the point light the cues are rendered with. The
  // flash's true power is unknown; the networks learn the scale, so any
  // fixed value works as long as rendering uses the same unit.
  double flash_intensity = 1.0;
  int threads = 0;              // 0 = all cores
  // The networks' light input (cue_frames.h, docs/relight.md "Baselines"):
  // "radiance" (DNL) or "sh" (the spherical-harmonics DNR baseline), and the
  // basis materials of the radiance cues (the 1-vs-5 basis ablation).
  std::string input = CueFormat::kRadiance;
  std::vector<std::string> bases = CueFormat::DefaultBasisNames();
  // The board and table as context geometry of the cue scene (support_plane.h):
  // the cues then hold the flash's bounce off the table and the shadows on it.
  // Without it an object's flank lit only by that bounce has black cues.
  bool support_plane = true;
  double paper_albedo = 0.8;     // linear albedo of the board's white paper
  double ink_albedo = 0.03;      // of its printed black
  double paper_margin_m = 0.01;  // white paper around the printed squares
  // Linear RGB of the table beyond the paper; empty = measured on the phone V
  // frames against the paper (support_albedo.h).
  std::vector<double> table_albedo;
  // The board's albedo map measured on the phone V frames (support_albedo.h):
  // what covers the print under the object (a coaster, a cloth) shows in the
  // cues' reflections and bounce light. false = the print as printed.
  bool board_albedo_map = true;
  double board_albedo_texel_m = 0.001;
  // What the proxy wears past the primary hit. "basis": each cue's own basis
  // material (DNL), so a part of the object mirrors the others as if they
  // were white. "fitted": the frames are rendered once so, a cue fit
  // (cue_texture_fit.h) of them gives every texel's weights, and the frames
  // are rendered again with the proxy wearing that mixture past the primary
  // hit: the cues then hold the inter-reflections between parts of
  // different materials. Needs the support plane (its paper gives the
  // flash's scale, which turns weights into reflectances) and the default
  // radiance bases.
  std::string secondary_material = "basis";
  int secondary_fit_resolution_px = 256;  // texel grid of that fit

  CueFormat Format() const { return {input, bases}; }
  // The JSON (OptionsToJson) holds `input` and `bases` only when not the
  // defaults, the board's albedos only with the support plane (older
  // records stay equal).
  static const OptionFields<CueStageOptions>& Fields();
  void Check() const;  // across fields; ranges and choices: CheckOptions
};

struct DatasetOptions {
  // Every n-th phone V frame (time order) is held out for validation; 0 =
  // none. Held-out frames never train any partition.
  int holdout_every = 8;
  // Frames whose light position calib flagged unreliable are dropped (true)
  // or kept (false).
  bool drop_unreliable_lights = true;
  // Quantile of the training targets' per-pixel maximum taken as the log
  // encoding's M (the scene's maximum radiance), times max_radiance_margin.
  double max_radiance_quantile = 0.999;
  double max_radiance_margin = 1.5;

  static const OptionFields<DatasetOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

// The views `relit-relight render` produces without explicit cameras:
// turntables around the object (proxy.json's centre), one under a point
// light that turns with the camera (a flash-like key light, offset up and
// to the side), one under an environment map.
struct RenderStageOptions {
  int frames = 24;                    // turntable frames (one revolution)
  int width_px = 0;                   // 0 = the training images' size
  int height_px = 0;
  double elevation_deg = 30.0;        // camera elevation above the board
  double distance_scale = 0;          // camera distance / object radius; 0 = as the capture
  double fps = 12.0;                  // MP4 frame rate
  // Point light: relative to the camera, in the camera's frame (x right, y
  // down, z forward), metres; intensity in flash units (1 = the capture's
  // flash as seen by the cues, see cues.flash_intensity).
  std::vector<double> point_light_offset_m = {0.1, -0.1, 0.0};
  double point_light_intensity = 1.0;
  // Environment map: an EXR/HDR file (equirectangular, +Z up) or
  // "procedural:sky" (a built-in sky with a sun) when empty.
  std::string environment_map;
  double environment_scale = 1.0;
  int samples_per_pixel = 16;         // cue rendering for new views
  bool denoise_cues = true;           // filter the cues' path-tracing noise (eval too)
  bool write_mp4 = true;

  static const OptionFields<RenderStageOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

}  // namespace relit::relight
