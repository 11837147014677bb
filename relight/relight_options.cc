// The readers of the relight stage's options (relight_options.h,
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
#include "core/options.h"

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

void NeuralTextureOptions::Read(OptionsReader& reader) {
  reader.ReadRange("resolution_px", &resolution_px, 1, 8192);
  reader.ReadRange("channels_per_basis", &channels_per_basis, 1, 64);
  reader.ReadRange("mip_levels", &mip_levels, 0, 14);
  reader.Read("init_min", &init_min);
  reader.Read("init_max", &init_max);
  reader.Finish();
  Check();
}

void NeuralTextureOptions::Check() const {
  RELIT_REQUIRE(resolution_px >= 1 && resolution_px <= 8192 && (resolution_px & (resolution_px - 1)) == 0,
                "texture resolution_px must be a power of two in [1, 8192], got ", resolution_px);
  RELIT_REQUIRE(channels_per_basis >= 1 && channels_per_basis <= 64,
                "channels_per_basis must be in [1, 64], got ", channels_per_basis);
  RELIT_REQUIRE(basis_count >= 0 && extra_channels >= 0 && channels() >= 1, "texture: no channels");
  RELIT_REQUIRE(mip_levels >= 0 && mip_levels <= 14, "mip_levels must be in [0, 14], got ", mip_levels);
  RELIT_REQUIRE(std::isfinite(init_min) && std::isfinite(init_max) && init_min <= init_max,
                "texture init_min must be <= init_max, got ", init_min, " > ", init_max);
}

nlohmann::json NeuralTextureOptions::ToJson() const {
  return {{"resolution_px", resolution_px}, {"channels_per_basis", channels_per_basis},
          {"mip_levels", mip_levels}, {"init_min", init_min}, {"init_max", init_max}};
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

void ModelOptions::Read(OptionsReader& reader) {
  reader.Read("variant", &variant);
  reader.Read("cue_fit", &cue_fit);
  reader.ReadRange("texture_resolution_px", &texture_resolution_px, 1, 8192);
  reader.ReadRange("object_window_margin_px", &object_window_margin_px, 0, 4096);
  reader.ReadRange("channels_per_basis", &channels_per_basis, 1, 64);
  reader.ReadRange("mip_levels", &mip_levels, 0, 14);
  reader.ReadRange("ngf", &ngf, 1, 512);
  reader.ReadRange("n_blocks", &n_blocks, 0, 64);
  reader.ReadRange("mask_ngf", &mask_ngf, 1, 512);
  reader.ReadRange("mask_n_blocks", &mask_n_blocks, 0, 64);
  reader.ReadRange("mask_band_px", &mask_band_px, 0, 4096);
  reader.Read("upsampling", &upsampling);
  reader.Read("norm", &norm);
  reader.Read("input_skip", &input_skip);
  reader.ReadRange("texture_init_spread", &texture_init_spread, 0.0, 1.0);
  reader.Read("max_radiance", &max_radiance);
  reader.Read("device", &device);
  reader.Finish();
  Check();
}

void ModelOptions::Check() const {
  format.Check();
  TextureOptions().Check();
  RendererOptions().Check();
  MaskOptions().Check();
  RELIT_REQUIRE(std::isfinite(max_radiance) && max_radiance >= 0,
                "model max_radiance must be finite and >= 0 (0 = set from the data), got ", max_radiance);
  RELIT_REQUIRE(device == "cpu" || device == "cuda" || device == "auto",
                "model device must be cpu, cuda or auto, got '", device, "'");
  RELIT_REQUIRE(variant == "residual" || variant == "dnl", "model variant must be residual or dnl, got '", variant,
                "'");
  RELIT_REQUIRE(cue_fit == "smooth" || cue_fit == "per_texel", "model cue_fit must be smooth or per_texel, got '",
                cue_fit, "'");
  RELIT_REQUIRE(!residual() || format.is_default(),
                "model variant residual starts from a least-squares regression of the 5 default radiance cues: "
                "it needs the default cues (no cues.input: sh, no other cues.bases); use model variant: dnl");
}

nlohmann::json ModelOptions::ToJson() const {
  nlohmann::json j = {{"variant", variant},
          {"cue_fit", cue_fit},
          {"texture_resolution_px", texture_resolution_px},
          {"object_window_margin_px", object_window_margin_px},
          {"channels_per_basis", channels_per_basis},
          {"mip_levels", mip_levels},
          {"ngf", ngf},
          {"n_blocks", n_blocks},
          {"mask_ngf", mask_ngf},
          {"mask_n_blocks", mask_n_blocks},
          {"mask_band_px", mask_band_px},
          {"upsampling", upsampling},
          {"norm", norm},
          {"input_skip", input_skip},
          {"texture_init_spread", texture_init_spread},
          {"max_radiance", max_radiance},
          {"device", device}};
  if (!format.is_default()) j.update(format.ToJson());
  return j;
}

void TrainOptions::Read(OptionsReader& reader) {
  reader.Read("learning_rate", &learning_rate);
  reader.Read("texture_learning_rate", &texture_learning_rate);
  reader.Read("regression_learning_rate", &regression_learning_rate);
  OptionsReader fit_reader = reader.Child("cue_fit");
  cue_fit.Read(fit_reader);
  reader.Read("beta1", &beta1);
  reader.Read("beta2", &beta2);
  reader.ReadRange("batch_size", &batch_size, 1, 1024);
  reader.ReadRange("crop_px", &crop_px, 0, 8192);
  reader.Read("mask_loss_weight", &mask_loss_weight);
  reader.ReadRange("matte_threshold", &matte_threshold, 0.0, 1.0);
  reader.Read("seed", &seed);
  reader.ReadRange("threads", &threads, 1, 256);
  reader.Finish();
  Check();
}

void TrainOptions::Check() const {
  RELIT_REQUIRE(learning_rate > 0 && learning_rate < 1, "learning_rate must be in (0, 1), got ", learning_rate);
  RELIT_REQUIRE(texture_learning_rate >= 0 && texture_learning_rate < 1,
                "texture_learning_rate must be in [0, 1) (0 = learning_rate), got ", texture_learning_rate);
  RELIT_REQUIRE(regression_learning_rate >= 0 && regression_learning_rate < 1,
                "regression_learning_rate must be in [0, 1) (0 = keep the least-squares fit), got ",
                regression_learning_rate);
  RELIT_REQUIRE(beta1 >= 0 && beta1 < 1 && beta2 >= 0 && beta2 < 1, "Adam beta1/beta2 must be in [0, 1)");
  RELIT_REQUIRE(batch_size >= 1, "batch_size must be >= 1, got ", batch_size);
  RELIT_REQUIRE(crop_px == 0 || (crop_px >= 8 && crop_px % 4 == 0),
                "crop_px must be 0 (no crop) or a multiple of 4 that is >= 8, got ", crop_px);
  RELIT_REQUIRE(mask_loss_weight >= 0 && std::isfinite(mask_loss_weight), "mask_loss_weight must be >= 0");
  RELIT_REQUIRE(threads >= 1 && threads <= 256, "threads must be in [1, 256], got ", threads);
  cue_fit.Check();
}

nlohmann::json TrainOptions::ToJson() const {
  return {{"learning_rate", learning_rate}, {"texture_learning_rate", texture_learning_rate},
          {"regression_learning_rate", regression_learning_rate}, {"beta1", beta1}, {"beta2", beta2},
          {"batch_size", batch_size}, {"crop_px", crop_px}, {"mask_loss_weight", mask_loss_weight},
          {"matte_threshold", matte_threshold},
          {"seed", seed}, {"threads", threads}, {"cue_fit", cue_fit.ToJson()}};
}

void TrainStageOptions::Read(OptionsReader& reader) {
  reader.ReadRange("steps", &steps, 1, 100000000);
  reader.ReadRange("checkpoint_every", &checkpoint_every, 1, 100000000);
  reader.ReadRange("validate_every", &validate_every, 0, 100000000);
  reader.ReadRange("log_every", &log_every, 1, 100000000);
  reader.ReadRange("max_validation_frames", &max_validation_frames, 0, 1000);
  reader.Read("validate_corrections", &validate_corrections);
  optimizer.Read(reader);  // the optimiser's keys sit at the same level; it calls Finish()
  Check();
}

void TrainStageOptions::Check() const {
  RELIT_REQUIRE(steps >= 1, "train.steps must be >= 1");
  RELIT_REQUIRE(checkpoint_every >= 1 && log_every >= 1, "train.checkpoint_every and train.log_every must be >= 1");
  RELIT_REQUIRE(validate_every >= 0 && max_validation_frames >= 0,
                "train.validate_every and train.max_validation_frames must be >= 0");
  optimizer.Check();
}

nlohmann::json TrainStageOptions::ToJson() const {
  json j = optimizer.ToJson();
  j["steps"] = steps;
  j["checkpoint_every"] = checkpoint_every;
  j["validate_every"] = validate_every;
  j["log_every"] = log_every;
  j["max_validation_frames"] = max_validation_frames;
  j["validate_corrections"] = validate_corrections;
  return j;
}

void AugmentOptions::Read(OptionsReader& r) {
  r.Read("enabled", &enabled);
  r.ReadRange("maps", &maps, 0, 100000);
  r.Read("map_dir", &map_dir);
  r.ReadRange("map_width_px", &map_width_px, 16, 8192);
  r.ReadRange("maps_per_view", &maps_per_view, 1, 1000);
  r.ReadRange("directions", &directions, 1, 100000);
  r.Read("sampling", &sampling);
  r.ReadRange("views", &views, 0, 1000000);
  r.ReadRange("resolution_scale", &resolution_scale, 0.05, 1.0);
  r.ReadRange("samples_per_pixel", &samples_per_pixel, 1, 1 << 16);
  r.ReadRange("map_samples_per_pixel", &map_samples_per_pixel, 1, 1 << 16);
  r.ReadRange("exposure", &exposure, 1e-6, 1e6);
  r.ReadRange("steps", &steps, 1, 100000000);
  r.ReadRange("checkpoint_every", &checkpoint_every, 1, 100000000);
  r.ReadRange("log_every", &log_every, 1, 100000000);
  r.Read("seed", &seed);
  r.Finish();
  Check();
}

void AugmentOptions::Check() const {
  RELIT_REQUIRE(sampling == "importance" || sampling == "all",
                "augment.sampling must be 'importance' or 'all', got '", sampling, "'");
  RELIT_REQUIRE(maps >= 0 && maps_per_view >= 1 && directions >= 1, "augment.maps must be >= 0, "
                "augment.maps_per_view and augment.directions >= 1");
  RELIT_REQUIRE(map_width_px >= 16 && map_width_px % 2 == 0, "augment.map_width_px must be even and >= 16");
  RELIT_REQUIRE(resolution_scale > 0 && resolution_scale <= 1, "augment.resolution_scale must be in (0, 1]");
  RELIT_REQUIRE(steps >= 1 && checkpoint_every >= 1 && log_every >= 1,
                "augment.steps, checkpoint_every and log_every must be >= 1");
  RELIT_REQUIRE(map_dir.empty() || fs::is_directory(map_dir), "augment.map_dir ", map_dir, " is not a folder");
}

nlohmann::json AugmentOptions::ToJson() const {
  return {{"enabled", enabled}, {"maps", maps}, {"map_dir", map_dir}, {"map_width_px", map_width_px},
          {"maps_per_view", maps_per_view}, {"directions", directions}, {"sampling", sampling},
          {"views", views}, {"resolution_scale", resolution_scale}, {"samples_per_pixel", samples_per_pixel},
          {"map_samples_per_pixel", map_samples_per_pixel},
          {"exposure", exposure}, {"steps", steps}, {"checkpoint_every", checkpoint_every},
          {"log_every", log_every}, {"seed", seed}};
}

void EvalOptions::Read(OptionsReader& r) {
  r.Read("methods", &methods);
  r.ReadRange("samples_per_pixel", &samples_per_pixel, 0, 1 << 16);
  r.ReadRange("environment_samples_per_pixel", &environment_samples_per_pixel, 0, 1 << 16);
  r.Read("seed", &seed);
  r.ReadRange("max_views", &max_views, 0, 100000);
  r.ReadRange("baseline_resolution_px", &baseline_resolution_px, 1, 4096);
  r.ReadRange("baseline_ridge", &baseline_ridge, 0.0, 1e9);
  r.ReadRange("cue_fit_resolution_px", &cue_fit_resolution_px, 1, 8192);
  OptionsReader fit_reader = r.Child("cue_fit");
  cue_fit.Read(fit_reader);
  r.ReadRange("error_map_scale", &error_map_scale, 0.0, 1e6);
  r.ReadRange("clip_radiance", &clip_radiance, 0.0, 1e9);
  r.Read("write_images", &write_images);
  r.Finish();
  Check();
}

void EvalOptions::Check() const {
  RELIT_REQUIRE(!methods.empty(),
                "eval.methods must list at least one of model, model_point_light, cue_fit, cues_only");
  std::set<std::string> seen;
  for (const std::string& m : methods) {
    RELIT_REQUIRE(std::find(KnownMethods().begin(), KnownMethods().end(), m) != KnownMethods().end(),
                  "eval.methods: unknown method '", m, "' (known: model, model_point_light, cue_fit, cues_only)");
    RELIT_REQUIRE(seen.insert(m).second, "eval.methods lists '", m, "' twice");
  }
  RELIT_REQUIRE(samples_per_pixel >= 0, "eval.samples_per_pixel must be >= 0 (0 = render.samples_per_pixel)");
  RELIT_REQUIRE(environment_samples_per_pixel >= 0,
                "eval.environment_samples_per_pixel must be >= 0 (0 = eval.samples_per_pixel)");
  cue_fit.Check();
  RELIT_REQUIRE(max_views >= 0, "eval.max_views must be >= 0 (0 = all)");
  RELIT_REQUIRE(baseline_resolution_px >= 1, "eval.baseline_resolution_px must be >= 1");
  RELIT_REQUIRE(baseline_ridge >= 0, "eval.baseline_ridge must be >= 0");
  RELIT_REQUIRE(error_map_scale > 0, "eval.error_map_scale must be > 0");
  RELIT_REQUIRE(clip_radiance >= 0, "eval.clip_radiance must be >= 0 (the capture's linear white level; 0 = no clip)");
}

nlohmann::json EvalOptions::ToJson() const {
  return {{"methods", methods},
          {"samples_per_pixel", samples_per_pixel},
          {"environment_samples_per_pixel", environment_samples_per_pixel},
          {"seed", seed},
          {"max_views", max_views},
          {"baseline_resolution_px", baseline_resolution_px},
          {"baseline_ridge", baseline_ridge},
          {"cue_fit_resolution_px", cue_fit_resolution_px},
          {"cue_fit", cue_fit.ToJson()},
          {"error_map_scale", error_map_scale},
          {"clip_radiance", clip_radiance},
          {"write_images", write_images}};
}

void InteropOptions::Read(OptionsReader& r) {
  r.Read("enabled", &enabled);
  r.Read("link_images", &link_images);
  r.ReadRange("bake_views", &bake_views, 1, 1000);
  r.ReadRange("bake_texture_px", &bake_texture_px, 16, 16384);
  r.ReadRange("bake_width_px", &bake_width_px, 0, 16384);
  r.ReadRange("bake_samples_per_pixel", &bake_samples_per_pixel, 0, 1 << 16);
  r.Read("bake_environment_radiance", &bake_environment_radiance);
  r.Read("bake_exposure", &bake_exposure);
  r.Finish();
  Check();
}

void InteropOptions::Check() const {
  RELIT_REQUIRE(bake_views >= 1, "interop.bake_views must be >= 1");
  RELIT_REQUIRE(bake_texture_px >= 16 && (bake_texture_px & (bake_texture_px - 1)) == 0,
                "interop.bake_texture_px must be a power of two >= 16, got ", bake_texture_px);
  RELIT_REQUIRE(bake_width_px >= 0 && bake_width_px % 4 == 0,
                "interop.bake_width_px must be 0 (training size) or a multiple of 4 (the networks downsample twice)");
  RELIT_REQUIRE(bake_samples_per_pixel >= 0, "interop.bake_samples_per_pixel must be >= 0 (0 = as the cues)");
  RELIT_REQUIRE(bake_environment_radiance > 0, "interop.bake_environment_radiance must be > 0");
  RELIT_REQUIRE(bake_exposure > 0, "interop.bake_exposure must be > 0");
}

nlohmann::json InteropOptions::ToJson() const {
  return {{"enabled", enabled},
          {"link_images", link_images},
          {"bake_views", bake_views},
          {"bake_texture_px", bake_texture_px},
          {"bake_width_px", bake_width_px},
          {"bake_samples_per_pixel", bake_samples_per_pixel},
          {"bake_environment_radiance", bake_environment_radiance},
          {"bake_exposure", bake_exposure}};
}

void RelightOptions::Read(OptionsReader& reader) {
  for (auto [key, read] : std::initializer_list<std::pair<const char*, std::function<void(OptionsReader&)>>>{
           {"cues", [&](OptionsReader& r) { cues.Read(r); }},
           {"dataset", [&](OptionsReader& r) { dataset.Read(r); }},
           {"partitions", [&](OptionsReader& r) { partitions.Read(r); }},
           {"model", [&](OptionsReader& r) { model.Read(r); }},
           {"train", [&](OptionsReader& r) { train.Read(r); }},
           {"augment", [&](OptionsReader& r) { augment.Read(r); }},
           {"render", [&](OptionsReader& r) { render.Read(r); }},
           {"export", [&](OptionsReader& r) { exports.Read(r); }},
           {"eval", [&](OptionsReader& r) { eval.Read(r); }}}) {
    OptionsReader child = reader.Child(key);
    read(child);
  }
  reader.Read("log_level", &log_level);
  reader.Finish();
  model.format = cues.Format();  // the model reads what the cues step renders
  model.Check();                 // e.g. variant residual with sh cues, refused before any step runs
}

void RelightOptions::Check() const {
  RELIT_REQUIRE(!workspace.empty(), "relight: --workspace is required");
  RELIT_REQUIRE(fs::is_directory(workspace), "relight: workspace ", workspace, " is not a folder");
  cues.Check();
  dataset.Check();
  partitions.Check();
  model.Check();
  train.Check();
  augment.Check();
  render.Check();
  exports.Check();
  eval.Check();
}

void CheckRelightSection(OptionsReader& reader) {
  RelightOptions options;
  options.Read(reader);  // every sub-reader checks its values and calls Finish()
}

nlohmann::json RelightOptions::ToJson() const {
  return {{"workspace", workspace},          {"cues", cues.ToJson()},   {"dataset", dataset.ToJson()},
          {"partitions", partitions.ToJson()}, {"model", model.ToJson()}, {"train", train.ToJson()},
          {"augment", augment.ToJson()},          {"render", render.ToJson()},        {"export", exports.ToJson()},
          {"eval", eval.ToJson()},            {"log_level", log_level}};
}

}  // namespace relit::relight
