// `relit-relight eval`: scores a trained workspace against the ground truth
// of a synthetic capture (relit-synth's truth.json, its "eval" set: held-out
// pinhole views, each rendered under point, directional and environment
// lights, with a GT alpha matte).
//
// For every (view, light) the proxy's cue frame is rendered once and fed to
// every method:
//   model              the workspace's final models (augmented when present)
//   model_point_light  the point-light models only, when some partition is
//                      augmented (before vs after augmentation)
//   cue_fit            the smooth cue regression (cue_texture_fit.h, the
//                      residual model's starting point) without any network,
//                      fitted on the plan's training frames
//   cues_only          the per-texel cue regression (cues_baseline.h) fitted
//                      on the plan's training frames
// Render and truth are clipped at the capture's white level
// (eval.clip_radiance), then scored: metrics.h (MAE, PSNR, alpha MAE on the
// GT foreground, linear) plus SSIM, per image, per light type and overall, go to OUT/eval.json (schema
// relit.eval/1) and OUT/eval.md; OUT/images/ holds the renders, |error| x 5
// maps and the ground truth as PNGs; OUT/run.json the run record.
//
// Light units: the cues were rendered with a point light of
// cues.flash_intensity (cue units) standing for the real flash, whose
// absolute power a capture cannot observe. Eval takes it from the truth:
// a GT light of strength S is rendered as S * flash_cue / flash_true, and
// the expected capture value is sensor.exposure * GT radiance.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/atomic_output.h"
#include "core/camera.h"
#include "core/image.h"
#include "relight/asset.h"
#include "relight/cue_frames.h"
#include "relight/cues_baseline.h"
#include "relight/metrics.h"
#include "relight/stage_options.h"

namespace relit {
class RunRecord;
}  // namespace relit

namespace relit::relight {

// Where eval keeps its cue frames between runs (EvalOptions::reuse_cue_frames).
inline constexpr const char* kEvalCueCacheDir = "relight/eval_cues";

// Key `eval:` of the relight section.
struct EvalOptions {
  // Methods to score, in table order: model, model_point_light, cue_fit,
  // cues_only. model_point_light is skipped (with a note) when no partition
  // is augmented.
  std::vector<std::string> methods = {"model", "model_point_light", "cue_fit", "cues_only"};
  int samples_per_pixel = 0;        // cue paths for the eval views; 0 = render.samples_per_pixel
  // Cue paths under environment lights, whose cues are far noisier than a
  // point or directional light's at equal samples (the prediction is linear
  // in the cues, so their noise is the prediction's). 0 = samples_per_pixel.
  int environment_samples_per_pixel = 0;
  uint64_t seed = 1;                // per-image cue seeds derive from it
  int max_views = 0;                // 0 = every eval view (else the first N of each view set, for quick checks)
  int baseline_resolution_px = 128; // cues_only texel grid
  double baseline_ridge = CuesOnlyBaseline::kDefaultRidge;  // cues_only pull towards the global fit (pixels' worth)
  int cue_fit_resolution_px = 256;  // cue_fit texel grid
  CueFitOptions cue_fit;            // the cue_fit method's other options (as train.cue_fit)
  double error_map_scale = 5.0;     // error PNGs show |pred - GT| x this
  // The capture's linear white level: render and truth are clipped per RGB
  // channel to [0, clip_radiance] before scoring, since an 8-bit video holds
  // nothing brighter (relit-synth: value = clamp(exposure x radiance);
  // relit-capture linearises sRGB / gamma 2.2 video to 1 = white).
  // capture.json records the transfer, not this level. 0 = no clip.
  double clip_radiance = kCaptureWhiteLevel;
  bool write_images = true;         // PNGs of renders, error maps and GT
  // Keep the rendered cue frames in W/relight/eval_cues/ and read them back
  // on the next eval of the same proxy, views, lights and cue settings
  // (eval_cue_cache.h): they are most of an eval's time.
  bool reuse_cue_frames = true;

  static const OptionFields<EvalOptions>& Fields();
  void Check() const;  // across fields; ranges and choices: CheckOptions
};

// One light of truth.json "eval".
struct TruthLight {
  std::string name;                 // e.g. "point_00"
  std::string type;                 // point | directional | environment
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();          // point
  Eigen::Vector3d direction_to_light = Eigen::Vector3d::UnitZ();  // directional
  Eigen::Vector3d rgb = Eigen::Vector3d::Ones();  // W/sr (point), irradiance (directional)
  std::string envmap;               // environment: absolute path of the map
  double scale = 1;                 // environment
};

struct TruthView {
  std::string name;                 // e.g. "view_00"
  Rigid3 cam_from_world;
  std::string alpha;                // absolute path
  std::map<std::string, std::string> images;  // light name -> absolute path
  // The truth's noise floor, from one of two renders per image (absent in
  // older captures): light name -> a second render with an independent seed
  // (truth.json "images_twin"), or one of the two independent halves whose
  // mean is the image ("images_half").
  std::map<std::string, std::string> twins;
  std::map<std::string, std::string> halves;
  double min_angle_to_training_rad = 0;
  // "interpolation" (on phone V's path between its frames) or "extrapolation"
  // (away from it; truth files without "set" held only these).
  std::string set = "extrapolation";
};

// The "eval" part of truth.json with what eval needs from the rest.
struct TruthEvalSet {
  std::string path;                 // truth.json
  Intrinsics intrinsics;            // undistorted pinhole
  std::vector<TruthLight> lights;
  std::vector<TruthView> views;
  double flash_intensity_w_per_sr = 0;  // mean of RGB
  double exposure = 1;              // sensor.exposure
};

// Reads and checks truth.json (schema relit.synth_truth/1). Throws
// relit::Error when it has no "eval" set or an image it lists is missing
// (naming the file).
TruthEvalSet ReadTruthEvalSet(const std::string& truth_json);

// The renderer's light for a GT light: strengths times `unit_factor`
// (flash_cue / flash_true).
CueLight ToCueLight(const TruthLight& light, double unit_factor);

// SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01, K2 0.03)
// of premultiplied RGB `predicted` against `reference_rgb` x `matte`, in
// linear values with dynamic range L = 1 (as PSNR's peak), per RGB channel
// and averaged, on the bounding box of the foreground (matte >= 0.5).
// NaN when there is no foreground.
double ForegroundSsim(const Image& predicted, const Image& reference_rgb, const Image& matte);

struct EvalImageResult {
  std::string view, light, light_type, method;
  std::string view_set = "extrapolation";  // the view's set in truth.json (interpolation | extrapolation)
  ImageMetrics metrics;
  double ssim = 0;
  std::string render_png, error_png, reference_png;  // relative to OUT; empty without images
};

// Writes OUT/eval.json and OUT/eval.md (eval_report.cc). `header` holds the
// fields besides the metrics (methods, light unit, options, timings).
// `floors`: the truth's noise floor per image (method kTruthNoiseFloor), or
// none when the truth has no twins.
void WriteEvalReport(const std::string& out_dir, const std::vector<EvalImageResult>& results,
                     const std::vector<std::string>& methods, nlohmann::json header,
                     const std::vector<EvalImageResult>& floors = {});

// Method name of the truth's noise floor rows (eval.json, eval.md).
inline constexpr const char* kTruthNoiseFloor = "truth_noise_floor";

// PNG helpers (eval_report.cc): premultiplied RGBA over grey, sRGB; GT RGB
// x matte over the same grey; |pred - GT x matte| x scale (linear, clipped).
void WriteRenderPng(const std::string& path, const Image& rgba);
// RGB x matte (clamped to [0, 1]) with the matte as alpha: premultiplied RGBA.
Image PremultipliedByMatte(const Image& rgb, const Image& matte);
// Truth | render | render ... side by side, cropped to the GT foreground's
// bounding box (+15 %) and enlarged by a whole factor to about `height_px`,
// over the same grey, sRGB. False (nothing written) without a foreground.
bool WriteZoomStripPng(const std::string& path, const Image& reference_rgb, const Image& matte,
                       const std::vector<const Image*>& renders, int height_px = 240);
void WriteReferencePng(const std::string& path, const Image& reference_rgb, const Image& matte);
void WriteErrorPng(const std::string& path, const Image& rgba, const Image& reference_rgb, const Image& matte,
                   double scale);

struct EvalSummary {
  std::string out_dir;
  int images = 0;                   // (view, light) pairs
  std::vector<std::string> methods;
};

// Short name of a model's light input for tables: "dnl" (radiance cues, the
// 5 default bases), "dnl_1_basis" / "dnl_N_bases" (other basis sets),
// "sh_dnr" (the spherical-harmonics DNR baseline).
std::string ModelVariantLabel(const CueFormat& format);

// Scores `workspace` against `truth_json` into `out_dir` (atomically).
// `render` gives the default samples per pixel. `guard` (a user's --out)
// applies the output-folder rule to `out_dir`. `models`: the set method
// "model" scores (FinalModels(augment.enabled)); "model_point_light" is
// scored only when that set holds augmented models.
EvalSummary RunEval(const std::string& workspace, const std::string& truth_json, const std::string& out_dir,
                    const EvalOptions& options, const RenderStageOptions& render, RunRecord& record,
                    const OutputGuard* guard = nullptr, ModelSet models = ModelSet::kFinal);

}  // namespace relit::relight
