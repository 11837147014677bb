// The options of the relight stage's learning steps (model, train, augment)
// and of the networks they build, without LibTorch: `relit run` checks a
// pipeline.yaml's whole `relight:` section with these readers before any
// step starts (pipeline/stage_check.cc). The torch code that uses them lives
// in model.h, neural_texture.h, networks.h, train_stage.h and augment.h.
// Defaults live here, keys, ranges and docs in the field tables
// (relight_options.cc), from which docs/relight.md's tables are generated.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "core/option_fields.h"
#include "relight/cue_frames.h"
#include "relight/cue_texture_fit.h"

namespace relit::relight {

constexpr int kBasisCount = 5;

struct NeuralTextureOptions {
  int resolution_px = 256;     // level 0 is resolution x resolution; a power of two
  int channels_per_basis = 6;  // C; the texture has basis_count C + extra_channels channels
  // Set by the model from its input format (not options of their own): 5
  // bases by default, 1 for the 1-basis ablation; the sh baseline uses
  // basis_count 1 (C pass-through channels) + 21 SH-modulated channels.
  int basis_count = kBasisCount;
  int extra_channels = 0;
  int mip_levels = 0;          // 0 = full chain down to 1 x 1
  // Initial texel values, uniform in [init_min, init_max]. Positive, so that
  // texture x cue starts as a (scaled) copy of the cue.
  double init_min = 0.5;
  double init_max = 1.5;

  int channels() const { return basis_count * channels_per_basis + extra_channels; }
  // Number of mip levels actually used.
  int levels() const;

  // Not a section of the file (ModelOptions::TextureOptions() builds it):
  // the table holds its ranges.
  static const OptionFields<NeuralTextureOptions>& Fields();
  void Check() const;  // across fields; ranges: CheckOptions
};

struct GeneratorOptions {
  int input_channels = 30;
  int output_channels = 3;
  int ngf = 32;                           // channels after the first conv
  int n_blocks = 6;                       // residual blocks at 1/4 resolution
  std::string upsampling = "transposed";  // "transposed" | "resize_conv"
  std::string norm = "instance";          // "instance" | "none"
  // The last 7x7 conv also sees the full-resolution input (a U-Net-like skip
  // over the down/up-sampling), so per-pixel detail need not be relearnt.
  bool input_skip = false;
  bool output_tanh = true;

  void Check() const;
  nlohmann::json ToJson() const;
};

struct ModelOptions {
  // "residual": the renderer network adds a log-space correction to a
  // per-texel linear regression of the cues (texture channels 0..2 of each
  // basis times that basis' cue RGB), fitted by least squares on the training
  // frames before the first step; the mask network corrects the proxy's
  // coverage. Both corrections start at zero, so the untrained model is the
  // cues-only regression. "dnl": the network's output is the image and the
  // mask net's the alpha, as in Deferred Neural Lighting.
  std::string variant = "residual";
  // The residual variant's cue regression: "smooth" (cue_texture_fit.h:
  // weights read bilinearly, neighbours share evidence) or "per_texel" (the
  // cues-only baseline's nearest-texel fit; checkpoints from before "smooth"
  // hold this one).
  std::string cue_fit = "smooth";
  int texture_resolution_px = 256;  // power of two
  // > 0: the networks see only the window around the proxy's coverage
  // (plus this margin) in training and rendering, instead of random crops
  // (train.crop_px) and whole frames: instance norm then sees the same
  // statistics in both. 0 = DNL's random crops and whole-frame renders.
  int object_window_margin_px = 16;
  int channels_per_basis = 6;       // C; the texture has 5 C channels
  int mip_levels = 0;               // 0 = full chain
  int ngf = 32;                     // renderer width (DNL: 64)
  int n_blocks = 6;                 // renderer residual blocks (DNL: 9)
  int mask_ngf = 16;                // mask network: half the renderer's channels
  int mask_n_blocks = 3;
  // Residual variant: a mask network corrects the proxy's coverage. Off by
  // default: learnt from the stage's mattes, its alpha was worse than the
  // coverage at every eval measured, and its loss, through the shared
  // texture, cost the colour 0.26 dB on the demo (docs/relight.md, "Alpha").
  // The dnl variant always has its mask network (its alpha).
  bool mask_correction = false;
  // Residual variant: the mask network corrects the coverage only within
  // this many pixels of it; alpha is 0 farther out (0 = everywhere).
  int mask_band_px = 8;
  // Residual variant: Render's image is blurred by a Gaussian this wide, in
  // texels of the texture (so the same on the object at any image scale; a
  // texel is about 1 mm on the demo's cow), within the proxy's coverage
  // (alpha stays the coverage). The proxy's position error puts detail
  // about a pixel off at new views, and the expected image under that error
  // is a blurred one (docs/relight.md, "Output blur"). -1 (auto): chosen
  // after training on the held-out frames (train.json `output_blur`) from
  // OutputBlurCandidates() by the one-standard-error rule: none where the
  // proxy is right (true inputs), about 1 texel on the demo. 0 = none (and
  // checkpoints from before it).
  double output_blur_texels = kAutoOutputBlur;
  static constexpr double kAutoOutputBlur = -1.0;
  std::string upsampling = "transposed";  // "transposed" | "resize_conv"
  std::string norm = "instance";          // "instance" | "none" (both networks)
  // The renderer's last conv also sees its input (full-resolution skip).
  // Not in DNL; +5 dB held-out at 300 steps (docs/relight.md, "Learning check").
  bool input_skip = true;
  // Texels start uniform in [1 - spread, 1 + spread]: texture x cue starts as
  // the cue itself, give or take the spread (noise the network must undo).
  double texture_init_spread = 0.5;
  // M of the log encoding, the scene's maximum radiance. 0 = not set yet:
  // whoever builds the model from data must set it (DnlModel requires > 0).
  double max_radiance = 0.0;
  std::string device = "cpu";       // "cpu", "cuda" or "auto" (cuda when available)
  // The light input the model reads (cues.input / cues.bases). Not a key of
  // `model:`; the stage copies it from `cues:`, checkpoints record it.
  CueFormat format;

  NeuralTextureOptions TextureOptions() const;
  GeneratorOptions RendererOptions() const;
  GeneratorOptions MaskOptions() const;
  bool residual() const { return variant == "residual"; }

  // The JSON (OptionsToJson) holds "input"/"bases" (format) only when not
  // the default, so records of default models are what they were before the
  // format existed.
  static const OptionFields<ModelOptions>& Fields();
  // Across fields (the networks' options, the format); ranges and choices:
  // CheckOptions.
  void Check() const;
};

struct TrainOptions {
  double learning_rate = 2e-4;  // Adam, as in DNL
  // The neural texture's Adam rate: each texel sees few pixels per step, so
  // it must move faster than the networks (measured, docs/relight.md).
  // 0 = learning_rate.
  double texture_learning_rate = 2e-2;
  // Adam rate of the residual model's cue-regression weights; 0 keeps the
  // least-squares fit they start from.
  double regression_learning_rate = 0.0;
  // The residual variant's warm start with model.cue_fit smooth.
  CueFitOptions cue_fit;
  double beta1 = 0.9;
  double beta2 = 0.999;
  int batch_size = 1;           // frames per step (the data loader's business)
  int crop_px = 128;            // random square crops; 0 = whole frames; multiple of 4
  double mask_loss_weight = 1.0;
  // > 0: the captured frames' mattes are thresholded at this alpha before
  // training (loss weights and the mask's target); 0 = soft mattes. The
  // closed-form mattes leave a halo of partial alpha over a textured board:
  // on the demo they are 0.0056 (MAE) from the true alpha, thresholded
  // 0.0030, the proxy's coverage 0.0035 (docs/relight.md).
  double matte_threshold = 0.5;
  uint64_t seed = 1;            // model initialisation and crop positions
  int threads = 2;              // torch intra-op threads

  static const OptionFields<TrainOptions>& Fields();
  void Check() const;  // across fields and bounds a range cannot say; ranges: CheckOptions
};

struct TrainStageOptions {
  int steps = 3000;              // optimisation steps per partition
  int checkpoint_every = 250;
  int validate_every = 500;      // 0 = only at the end
  int log_every = 10;
  int max_validation_frames = 4; // validation renders whole frames: keep it small
  // Residual model: after training, each correction network stays only if
  // it beats the cue regression / the proxy's coverage on the validation
  // frames (train_loop.h KeepHelpfulCorrections); false = keep both.
  // Off by default: the choice is saved into the checkpoint, so training
  // continued with more steps no longer reproduces an uninterrupted run.
  bool validate_corrections = false;
  TrainOptions optimizer;        // Adam, crops, seed, threads (same keys, same level)

  static const OptionFields<TrainStageOptions>& Fields();
};

struct AugmentOptions {
  bool enabled = true;               // the pipeline runs augment steps
  int maps = 60;                     // procedural maps in the set (DNL used 90 captured ones)
  std::string map_dir;               // optional folder of .exr/.hdr maps (equirectangular, +Z up)
  int map_width_px = 256;
  int maps_per_view = 5;
  int directions = 100;              // directional lights per view
  std::string sampling = "importance";  // "importance" | "all"
  int views = 0;                     // augmented training views per partition; 0 = all
  double resolution_scale = 1.0;     // augmented frames' size / the training frames' size
  int samples_per_pixel = 4;         // cue paths per pixel under each directional light
  int map_samples_per_pixel = 16;    // cue paths per pixel under a map (the networks' input)
  double exposure = 1.0;             // map irradiance / the flash's at the capture distance
  int steps = 1000;                  // fine-tuning steps, alternating captured / augmented
  int checkpoint_every = 250;
  int log_every = 10;
  uint64_t seed = 1;

  static const OptionFields<AugmentOptions>& Fields();
  void Check() const;  // across fields and the file system; ranges and choices: CheckOptions
};

}  // namespace relit::relight
