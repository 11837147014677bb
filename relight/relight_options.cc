// The field tables of the relight stage's options (relight_options.h,
// learn_options.h, eval.h, interop.h): no LibTorch, so the orchestrator can
// check a whole `relight:` section (relit_relight_data).
#include "relight/relight_options.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <utility>

#include "core/error.h"
#include "core/log.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

int Log2Exact(int value) {
  int log = 0;
  while ((1 << log) < value) ++log;
  return log;
}

const std::vector<std::string>& KnownMethods() {
  static const std::vector<std::string> methods = {"model", "model_point_light", "cue_fit", "cues_only"};
  return methods;
}

}  // namespace

int NeuralTextureOptions::levels() const {
  const int full = Log2Exact(resolution_px) + 1;
  return mip_levels == 0 ? full : std::min(mip_levels, full);
}

RELIT_OPTION_FIELDS(NeuralTextureOptions,
    .Add("resolution_px", &S::resolution_px, 1, 8192, "level 0 size; a power of two")
    .Add("channels_per_basis", &S::channels_per_basis, 1, 64, "C")
    .Add("mip_levels", &S::mip_levels, 0, 14, "0 = full chain")
    .Add("init_min", &S::init_min, "initial texels uniform in [init_min, init_max]")
    .Add("init_max", &S::init_max, "see init_min"))

void NeuralTextureOptions::Check() const {
  RELIT_REQUIRE((resolution_px & (resolution_px - 1)) == 0,
                "texture resolution_px must be a power of two in [1, 8192], got ", resolution_px);
  RELIT_REQUIRE(basis_count >= 0 && extra_channels >= 0 && channels() >= 1, "texture: no channels");
  RELIT_REQUIRE(std::isfinite(init_min) && std::isfinite(init_max) && init_min <= init_max,
                "texture init_min must be <= init_max, got ", init_min, " > ", init_max);
}

void GeneratorOptions::Check() const {
  RELIT_REQUIRE(input_channels >= 1 && output_channels >= 1, "generator: channel counts must be >= 1");
  RELIT_REQUIRE(ngf >= 1 && ngf <= 512, "generator ngf must be in [1, 512], got ", ngf);
  RELIT_REQUIRE(n_blocks >= 0 && n_blocks <= 64, "generator n_blocks must be in [0, 64], got ", n_blocks);
  RELIT_REQUIRE(upsampling == "transposed" || upsampling == "resize_conv",
                "generator upsampling must be transposed or resize_conv, got '", upsampling, "'");
  RELIT_REQUIRE(norm == "instance" || norm == "none", "generator norm must be instance or none, got '", norm, "'");
}

nlohmann::json GeneratorOptions::ToJson() const {
  return {{"input_channels", input_channels}, {"output_channels", output_channels}, {"ngf", ngf},
          {"n_blocks", n_blocks}, {"upsampling", upsampling}, {"norm", norm}, {"input_skip", input_skip}, {"output_tanh", output_tanh}};
}

NeuralTextureOptions ModelOptions::TextureOptions() const {
  NeuralTextureOptions t;
  t.resolution_px = texture_resolution_px;
  t.channels_per_basis = channels_per_basis;
  t.mip_levels = mip_levels;
  t.init_min = 1.0 - texture_init_spread;
  t.init_max = 1.0 + texture_init_spread;
  if (format.is_sh()) {
    t.basis_count = 1;  // C pass-through channels
    t.extra_channels = format.light_channels();
  } else {
    t.basis_count = static_cast<int>(format.bases.size());
  }
  return t;
}

GeneratorOptions ModelOptions::RendererOptions() const {
  GeneratorOptions g;
  g.input_channels = TextureOptions().channels();
  g.output_channels = 3;
  g.ngf = ngf;
  g.n_blocks = n_blocks;
  g.upsampling = upsampling;
  g.norm = norm;
  g.input_skip = input_skip;
  g.output_tanh = true;
  return g;
}

GeneratorOptions ModelOptions::MaskOptions() const {
  GeneratorOptions g = RendererOptions();
  g.output_channels = 1;
  g.ngf = mask_ngf;
  g.n_blocks = mask_n_blocks;
  g.output_tanh = false;  // a logit
  return g;
}

RELIT_OPTION_FIELDS(ModelOptions,
    .Add("variant", &S::variant, {"residual", "dnl"},
         "residual: cue regression + corrections; dnl: Deferred Neural Lighting's networks (\"Model variants\")")
    .Add("cue_fit", &S::cue_fit, {"smooth", "per_texel"},
         "the residual variant's regression: bilinear (\"Smooth cue fit\") or the cues-only baseline's "
         "nearest-texel fit")
    .Add("texture_resolution_px", &S::texture_resolution_px, 1, 8192,
         "neural texture level 0 (and the residual variant's regression grid), a power of two")
    .Add("object_window_margin_px", &S::object_window_margin_px, 0, 4096,
         "the networks see the object's window plus this margin; 0 = random crops and whole frames, as DNL")
    .Add("channels_per_basis", &S::channels_per_basis, 1, 64, "C; the texture has bases x C channels")
    .Add("mip_levels", &S::mip_levels, 0, 14, "0 = full chain")
    .Add("ngf", &S::ngf, 1, 512, "renderer width (DNL: 64)")
    .Add("n_blocks", &S::n_blocks, 0, 64, "renderer residual blocks (DNL: 9)")
    .Add("mask_ngf", &S::mask_ngf, 1, 512, "mask network width")
    .Add("mask_n_blocks", &S::mask_n_blocks, 0, 64, "mask network residual blocks")
    .Add("mask_correction", &S::mask_correction,
         "residual variant: a mask network corrects the proxy's coverage (off: alpha is the coverage; the dnl "
         "variant always has its mask network)")
    .Add("mask_band_px", &S::mask_band_px, 0, 4096,
         "residual variant: the mask network corrects the coverage only within this many pixels of it; "
         "alpha is 0 farther out (0 = everywhere, as checkpoints from before it)")
    .Add("output_blur_texels", &S::output_blur_texels, ModelOptions::kAutoOutputBlur, 64.0,
         "residual variant: Gaussian blur of the rendered colour within the coverage, in texels of the texture; "
         "-1 = chosen on the held-out frames after training, 0 = none (\"Output blur\")")
    .Add("upsampling", &S::upsampling, {"transposed", "resize_conv"}, "the networks' upsampling")
    .Add("norm", &S::norm, {"instance", "none"}, "both networks' normalisation (DNL: instance)")
    .Add("input_skip", &S::input_skip,
         "the renderer's last 7x7 conv also reads the network input (not in DNL; \"Learning check\")")
    .Add("texture_init_spread", &S::texture_init_spread, 0.0, 1.0, "texels start uniform in [1 - s, 1 + s]")
    .Add("max_radiance", &S::max_radiance, "M of the log encoding; 0 = set from the data")
    .Add("device", &S::device, {"cpu", "cuda", "auto"}, "auto: cuda when available")
    .OnToJson([](const S& s, nlohmann::json* json) {
      if (!s.format.is_default()) json->update(s.format.ToJson());
    }))

void ModelOptions::Check() const {
  format.Check();
  CheckOptions(TextureOptions(), "texture");
  RendererOptions().Check();
  MaskOptions().Check();
  RELIT_REQUIRE(std::isfinite(max_radiance) && max_radiance >= 0,
                "model max_radiance must be finite and >= 0 (0 = set from the data), got ", max_radiance);
  RELIT_REQUIRE(!residual() || format.is_default(),
                "model variant residual starts from a least-squares regression of the 5 default radiance cues: "
                "it needs the default cues (no cues.input: sh, no other cues.bases); use model variant: dnl");
}

RELIT_OPTION_FIELDS(TrainOptions,
    .Add("learning_rate", &S::learning_rate, "the networks' Adam rate, in (0, 1)")
    .Add("texture_learning_rate", &S::texture_learning_rate,
         "the neural texture's Adam rate, in [0, 1); 0 = learning_rate")
    .Add("regression_learning_rate", &S::regression_learning_rate,
         "the residual variant's regression weights' Adam rate, in [0, 1); 0 = keep the least-squares fit")
    .Section("cue_fit", &S::cue_fit)
    .Add("beta1", &S::beta1, "Adam beta1, in [0, 1)")
    .Add("beta2", &S::beta2, "Adam beta2, in [0, 1)")
    .Add("batch_size", &S::batch_size, 1, 1024, "frames per step")
    .Add("crop_px", &S::crop_px, 0, 8192,
         "random square crops (only with model.object_window_margin_px: 0); 0 = whole frames, "
         "else a multiple of 4 >= 8")
    .Add("mask_loss_weight", &S::mask_loss_weight, "weight of the mask loss; >= 0")
    .Add("matte_threshold", &S::matte_threshold, 0.0, 1.0,
         "the captured frames' mattes are thresholded at this alpha for the loss weights and the mask's "
         "target; 0 = soft mattes (\"Alpha\")")
    .Add("seed", &S::seed, "model initialisation and crop positions")
    .Add("threads", &S::threads, 1, 256, "torch intra-op threads"))

void TrainOptions::Check() const {
  RELIT_REQUIRE(learning_rate > 0 && learning_rate < 1, "learning_rate must be in (0, 1), got ", learning_rate);
  RELIT_REQUIRE(texture_learning_rate >= 0 && texture_learning_rate < 1,
                "texture_learning_rate must be in [0, 1) (0 = learning_rate), got ", texture_learning_rate);
  RELIT_REQUIRE(regression_learning_rate >= 0 && regression_learning_rate < 1,
                "regression_learning_rate must be in [0, 1) (0 = keep the least-squares fit), got ",
                regression_learning_rate);
  RELIT_REQUIRE(beta1 >= 0 && beta1 < 1 && beta2 >= 0 && beta2 < 1, "Adam beta1/beta2 must be in [0, 1)");
  RELIT_REQUIRE(crop_px == 0 || (crop_px >= 8 && crop_px % 4 == 0),
                "crop_px must be 0 (no crop) or a multiple of 4 that is >= 8, got ", crop_px);
  RELIT_REQUIRE(mask_loss_weight >= 0 && std::isfinite(mask_loss_weight), "mask_loss_weight must be >= 0");
}

RELIT_OPTION_FIELDS(TrainStageOptions,
    .Add("steps", &S::steps, 1, 100000000, "optimisation steps per partition")
    .Add("checkpoint_every", &S::checkpoint_every, 1, 100000000, "steps between checkpoints")
    .Add("validate_every", &S::validate_every, 0, 100000000, "steps between validations; 0 = only at the end")
    .Add("log_every", &S::log_every, 1, 100000000, "steps between log lines")
    .Add("max_validation_frames", &S::max_validation_frames, 0, 1000, "whole-frame renders per validation")
    .Add("validate_corrections", &S::validate_corrections,
         "residual model: after training, each correction network stays only if it beats the cue regression "
         "/ the proxy's coverage on the validation frames (recorded in train.json corrections); off by "
         "default: the choice is saved into the checkpoint, so a continued training would not reproduce an "
         "uninterrupted run")
    .Inline(&S::optimizer))

RELIT_OPTION_FIELDS(AugmentOptions,
    .Add("enabled", &S::enabled, "the pipeline runs the augment steps")
    .Add("maps", &S::maps, 0, 100000, "procedural environment maps in the set")
    .Add("map_dir", &S::map_dir, "a folder of the user's .exr/.hdr maps (equirectangular, +Z up) added to the set")
    .Add("map_width_px", &S::map_width_px, 16, 8192, "procedural map width; even")
    .Add("maps_per_view", &S::maps_per_view, 1, 1000, "maps drawn per augmented view")
    .Add("directions", &S::directions, 1, 100000, "directional lights per view")
    .Add("sampling", &S::sampling, {"importance", "all"},
         "the directions: importance (a mixture of the view's maps) or all (a fixed Fibonacci set, "
         "Voronoi-cell weights)")
    .Add("views", &S::views, 0, 1000000, "augmented training views per partition, evenly spread; 0 = all")
    .Add("resolution_scale", &S::resolution_scale, 0.05, 1.0, "augmented frame size / training frame size")
    .Add("samples_per_pixel", &S::samples_per_pixel, 1, 1 << 16, "cue paths per pixel under each directional light")
    .Add("map_samples_per_pixel", &S::map_samples_per_pixel, 1, 1 << 16, "cue paths per pixel under a map")
    .Add("exposure", &S::exposure, 1e-6, 1e6, "map irradiance / the flash's irradiance at the capture distance")
    .Add("steps", &S::steps, 1, 100000000, "fine-tuning steps, alternating captured and augmented frames")
    .Add("checkpoint_every", &S::checkpoint_every, 1, 100000000, "steps between checkpoints")
    .Add("log_every", &S::log_every, 1, 100000000, "steps between log lines")
    .Add("seed", &S::seed, "map family, draws and directions"))

void AugmentOptions::Check() const {
  RELIT_REQUIRE(map_width_px % 2 == 0, "map_width_px must be even, got ", map_width_px);
  RELIT_REQUIRE(map_dir.empty() || fs::is_directory(map_dir), "map_dir ", map_dir, " is not a folder");
}

RELIT_OPTION_FIELDS(EvalOptions,
    .Add("methods", &S::methods, KnownMethods(),
         "what eval scores, in table order (\"Evaluation\"); model_point_light is skipped when no partition "
         "is augmented")
    .Add("samples_per_pixel", &S::samples_per_pixel, 0, 1 << 16,
         "cue paths for the eval views; 0 = render.samples_per_pixel")
    .Add("environment_samples_per_pixel", &S::environment_samples_per_pixel, 0, 1 << 16,
         "cue paths under environment lights, whose cues are far noisier at equal samples (the prediction is "
         "linear in the cues); 0 = eval.samples_per_pixel")
    .Add("seed", &S::seed, "per-image cue seeds derive from it")
    .Add("max_views", &S::max_views, 0, 100000, "0 = every eval view, else the first N of each view set")
    .Add("baseline_resolution_px", &S::baseline_resolution_px, 1, 4096, "the cues-only baseline's texel grid")
    .Add("baseline_ridge", &S::baseline_ridge, 0.0, 1e9,
         "the cues-only baseline's pull towards the global fit (pixels' worth)")
    .Add("cue_fit_resolution_px", &S::cue_fit_resolution_px, 1, 8192, "the cue_fit method's texel grid")
    .Section("cue_fit", &S::cue_fit)
    .Add("error_map_scale", &S::error_map_scale, 0.0, 1e6, "error PNGs show |pred - GT| x this; > 0")
    .Add("clip_radiance", &S::clip_radiance, 0.0, 1e9,
         "the capture's linear white level: render and truth are clipped per RGB channel to [0, this] before "
         "scoring; 0 = no clip (\"Evaluation\")")
    .Add("write_images", &S::write_images, "PNGs of renders, error maps and the truth")
    .Add("reuse_cue_frames", &S::reuse_cue_frames,
         "keep the eval views' cue frames in W/relight/eval_cues/ and read them back when proxy, views, lights, "
         "cue settings and renderer are unchanged (most of an eval's time); false = render every run"))

void EvalOptions::Check() const {
  RELIT_REQUIRE(!methods.empty(), "methods must list at least one of model, model_point_light, cue_fit, cues_only");
  std::set<std::string> seen;
  for (const std::string& m : methods) RELIT_REQUIRE(seen.insert(m).second, "methods lists '", m, "' twice");
  RELIT_REQUIRE(error_map_scale > 0, "error_map_scale must be > 0");
}

RELIT_OPTION_FIELDS(InteropOptions,
    .Add("enabled", &S::enabled, "write <asset>/interop at all (`--no-interop`)")
    .Add("link_images", &S::link_images, "hard-link frames where possible (copy otherwise)")
    .Add("bake_views", &S::bake_views, 1, 1000,
         "preview bake: renders on the upper hemisphere around the object (`--bake-views`)")
    .Add("bake_texture_px", &S::bake_texture_px, 16, 16384,
         "square bake texture, a power of two (`--bake-texture-px`)")
    .Add("bake_width_px", &S::bake_width_px, 0, 16384,
         "bake render width; 0 = the training images', else a multiple of 4 (`--bake-width-px`)")
    .Add("bake_samples_per_pixel", &S::bake_samples_per_pixel, 0, 1 << 16,
         "cue paths per bake pixel; 0 = as the training cues (`--bake-samples-per-pixel`)")
    .Add("bake_environment_radiance", &S::bake_environment_radiance,
         "radiance of the bake's uniform white environment, in the cues' unit; > 0")
    .Add("bake_exposure", &S::bake_exposure,
         "linear scale before the texture's sRGB encoding; > 0 (`--bake-exposure`)"))

void InteropOptions::Check() const {
  RELIT_REQUIRE((bake_texture_px & (bake_texture_px - 1)) == 0, "bake_texture_px must be a power of two >= 16, got ",
                bake_texture_px);
  RELIT_REQUIRE(bake_width_px % 4 == 0,
                "bake_width_px must be 0 (training size) or a multiple of 4 (the networks downsample twice)");
  RELIT_REQUIRE(bake_environment_radiance > 0, "bake_environment_radiance must be > 0");
  RELIT_REQUIRE(bake_exposure > 0, "bake_exposure must be > 0");
}

RELIT_OPTION_FIELDS(RelightOptions,
    .Section("cues", &S::cues)
    .Section("dataset", &S::dataset)
    .Section("partitions", &S::partitions)
    .Section("model", &S::model)
    .Section("train", &S::train)
    .Section("augment", &S::augment)
    .Section("render", &S::render)
    .Section("export", &S::exports)
    .Section("eval", &S::eval)
    .Add("log_level", &S::log_level, LogLevelNames(), "what the stage prints (`--log-level`)")
    // The model reads what the cues step renders.
    .OnRead([](OptionsReader&, S* s) { s->model.format = s->cues.Format(); })
    .OnToJson([](const S& s, nlohmann::json* json) { (*json)["workspace"] = s.workspace; }))

RelightOptions ReadRelightSection(OptionsReader& reader) {
  RelightOptions options;
  ReadOptions(reader, &options);
  CheckOptions(options);  // e.g. variant residual with sh cues, refused before any step runs
  return options;
}

void CheckRelightSection(OptionsReader& reader) { ReadRelightSection(reader); }

}  // namespace relit::relight
