#include "relight/eval.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <set>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/capture_file.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/stage_run.h"
#include "relight/asset.h"
#include "relight/cue_stage.h"
#include "relight/cue_texture_fit.h"
#include "relight/cues_baseline.h"
#include "relight/eval_cue_cache.h"
#include "relight/plan.h"
#include "relight/render_stage.h"
#include "relight/train_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// truth.json's RGB strengths are a number or [r, g, b].
Eigen::Vector3d Rgb(const json& j, const std::string& key, const std::string& where) {
  const json& v = JsonField(j, key, where);
  if (v.is_number()) return Eigen::Vector3d::Constant(v.get<double>());
  return Vector3FromJson(v, where + "." + key);
}

json ToJsonArray(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

}  // namespace




TruthEvalSet ReadTruthEvalSet(const std::string& truth_json) {
  RELIT_REQUIRE(fs::exists(truth_json), "ground truth ", truth_json,
                " does not exist (relit-synth writes truth.json next to the capture's videos)");
  const json truth = ReadJsonFile(truth_json, "synth_truth", 1);
  const fs::path root = fs::absolute(truth_json).parent_path();
  TruthEvalSet set;
  set.path = truth_json;
  RELIT_REQUIRE(truth.contains("eval") && truth["eval"].is_object(), truth_json,
                ": no \"eval\" set (held-out views with ground-truth images); render the capture with relit-synth "
                "without --truth-only and with eval_views > 0");
  RELIT_REQUIRE(truth.value("rendered", true), truth_json,
                ": the evaluation images were not rendered (a --truth-only run); rerun relit-synth without --truth-only");
  const json& eval = truth["eval"];
  const std::string where = truth_json + ": eval";
  set.intrinsics = IntrinsicsFromJson(JsonField(eval, "intrinsics", where), where + ".intrinsics");
  set.flash_intensity_w_per_sr = Rgb(JsonField(truth, "flash", truth_json), "intensity_w_per_sr", truth_json + ": flash").mean();
  RELIT_REQUIRE(set.flash_intensity_w_per_sr > 0, truth_json, ": flash.intensity_w_per_sr must be > 0");
  if (truth.contains("sensor")) set.exposure = truth["sensor"].value("exposure", 1.0);
  int index = 0;
  for (const json& l : JsonField(eval, "lights", where)) {
    const std::string at = where + ".lights[" + std::to_string(index++) + "]";
    TruthLight light;
    light.name = JsonString(l, "name", at);
    light.type = JsonString(l, "type", at);
    if (light.type == "point") {
      light.position_m = Vector3FromJson(JsonField(l, "position_world_m", at), at + ".position_world_m");
      light.rgb = Rgb(l, "intensity_w_per_sr", at);
    } else if (light.type == "directional") {
      light.direction_to_light =
          Vector3FromJson(JsonField(l, "direction_to_light_world", at), at + ".direction_to_light_world").normalized();
      light.rgb = Rgb(l, "irradiance", at);
    } else if (light.type == "environment") {
      light.envmap = (root / JsonString(l, "envmap", at)).string();
      light.scale = l.value("scale", 1.0);
      RELIT_REQUIRE(fs::exists(light.envmap), at, ": environment map ", light.envmap, " is missing");
    } else {
      Fail(at, ": light type must be point, directional or environment, got '", light.type, "'");
    }
    set.lights.push_back(light);
  }
  index = 0;
  for (const json& v : JsonField(eval, "views", where)) {
    const std::string at = where + ".views[" + std::to_string(index++) + "]";
    TruthView view;
    view.name = JsonString(v, "name", at);
    RELIT_REQUIRE(!view.name.empty() && view.name.find('/') == std::string::npos, at, ": name must be a plain name");
    view.cam_from_world = Rigid3FromJson(JsonField(v, "cam_from_world", at), at + ".cam_from_world");
    view.alpha = (root / JsonString(v, "alpha", at)).string();
    view.min_angle_to_training_rad = v.value("min_angle_to_training_views_rad", 0.0);
    view.set = v.value("set", std::string("extrapolation"));
    RELIT_REQUIRE(view.set == "interpolation" || view.set == "extrapolation", at,
                  ": set must be interpolation or extrapolation, got '", view.set, "'");
    const json& images = JsonField(v, "images", at);
    for (const TruthLight& light : set.lights) {
      RELIT_REQUIRE(images.contains(light.name), at, ": no image for light ", light.name);
      view.images[light.name] = (root / images[light.name].get<std::string>()).string();
    }
    for (const auto& [key, paths] : {std::pair{"images_twin", &view.twins}, std::pair{"images_half", &view.halves}}) {
      if (!v.contains(key)) continue;
      const json& listed = JsonField(v, key, at);
      for (const TruthLight& light : set.lights) {
        if (listed.contains(light.name)) (*paths)[light.name] = (root / listed[light.name].get<std::string>()).string();
      }
    }
    std::vector<std::string> files = {view.alpha};
    for (const auto& [name, path] : view.images) files.push_back(path);
    for (const auto& [name, path] : view.twins) files.push_back(path);
    for (const auto& [name, path] : view.halves) files.push_back(path);
    for (const std::string& file : files) {
      RELIT_REQUIRE(fs::exists(file), "ground-truth image ", file, " is missing (listed in ", truth_json,
                    " for view ", view.name, "); re-render the capture with relit-synth");
    }
    set.views.push_back(view);
  }
  RELIT_REQUIRE(!set.views.empty() && !set.lights.empty(), truth_json, ": the eval set has no views or no lights");
  return set;
}

std::string ModelVariantLabel(const CueFormat& format) {
  if (format.is_sh()) return "sh_dnr";
  if (format.is_default()) return "dnl";
  const size_t n = format.bases.size();
  return "dnl_" + std::to_string(n) + (n == 1 ? "_basis" : "_bases");
}

CueLight ToCueLight(const TruthLight& light, double unit_factor) {
  // Through the same JSON light parser as `render --views`.
  json j;
  if (light.type == "point") {
    j = {{"type", "point"}, {"position_m", ToJsonArray(light.position_m)},
         {"intensity", ToJsonArray(light.rgb * unit_factor)}};
  } else if (light.type == "directional") {
    j = {{"type", "directional"}, {"direction_to_light", ToJsonArray(light.direction_to_light)},
         {"irradiance", ToJsonArray(light.rgb * unit_factor)}};
  } else {
    j = {{"type", "environment"}, {"map", light.envmap}, {"scale", light.scale * unit_factor}};
  }
  return LightFromJson(j, "", "eval light " + light.name);
}

namespace {

Image Scaled(Image image, double factor) {
  if (factor != 1.0) {
    for (float& v : image.data()) v *= static_cast<float>(factor);
  }
  return image;
}

void RequireSize(const Image& image, const Intrinsics& intrinsics, const std::string& path) {
  RELIT_REQUIRE(image.width() == intrinsics.width && image.height() == intrinsics.height, path, " is ",
                image.width(), "x", image.height(), ", truth.json's eval intrinsics say ", intrinsics.width, "x",
                intrinsics.height);
}

EvalImageResult ResultFor(const TruthView& view, const TruthLight& light, const std::string& method) {
  EvalImageResult r;
  r.view = view.name;
  r.light = light.name;
  r.light_type = light.type;
  r.method = method;
  r.view_set = view.set;
  return r;
}

// The truth's own noise, scored as a method would be: the score a perfect
// prediction of the converged image gets against this truth. From a twin
// (same image, independent seed) the pair's difference holds twice one
// render's variance, so the floor is half the pair's MSE. From a half (the
// image is the mean of it and an independent other half) the difference
// to the image is half the halves' difference, whose MSE is the image's own
// noise variance: the floor is that MSE as it is.
EvalImageResult TruthNoiseFloor(const TruthView& view, const TruthLight& light, const Image& reference,
                                const Image& matte, const TruthEvalSet& truth, double clip_radiance) {
  const bool from_half = view.halves.count(light.name) > 0;
  const std::string& path = from_half ? view.halves.at(light.name) : view.twins.at(light.name);
  Image other = ReadImage(path);
  RELIT_REQUIRE(other.channels() >= 3, path, " has ", other.channels(), " channels, expected RGB");
  RequireSize(other, truth.intrinsics, path);
  other = Scaled(other.SelectChannels(std::vector<int>{0, 1, 2}), truth.exposure);
  ClipRadiance(&other, clip_radiance);
  const Image premultiplied = PremultipliedByMatte(other, matte);
  EvalImageResult r = ResultFor(view, light, kTruthNoiseFloor);
  r.metrics = CompareToReference(premultiplied, reference, matte);
  if (!from_half) {
    r.metrics.mse /= 2;
    r.metrics.mae /= std::sqrt(2.0);
  }
  r.metrics.psnr_db = r.metrics.mse > 0 ? 10 * std::log10(1 / r.metrics.mse) : 99;
  r.ssim = ForegroundSsim(premultiplied, reference, matte);
  return r;
}

// The cue-frame cache of this eval (eval_cue_cache.h), off with
// eval.reuse_cue_frames false. Its common key holds everything a frame
// depends on besides its view, light, samples and seed; `light_keys` gets
// each truth light's part (environment maps by content).
EvalCueCache OpenCueCache(const fs::path& root, const EvalOptions& options, const AssetDescription& asset,
                          const CueFormat& format, const CueRenderSettings& settings, double unit_factor,
                          const TruthEvalSet& truth, const std::vector<size_t>& selected, render::Scene& scene,
                          std::vector<json>* light_keys) {
  light_keys->clear();
  if (!options.reuse_cue_frames || selected.empty() || truth.lights.empty()) {
    light_keys->resize(truth.lights.size());
    return EvalCueCache({}, {}, format);
  }
  for (const TruthLight& light : truth.lights) {
    json key = {{"type", light.type}, {"position_m", ToJson(light.position_m)},
                {"direction_to_light", ToJson(light.direction_to_light)}, {"rgb", ToJson(light.rgb)},
                {"scale", light.scale}};
    if (!light.envmap.empty()) key["envmap"] = HashFile(light.envmap);
    light_keys->push_back(key);
  }
  const Camera probe_camera(truth.intrinsics, truth.views[selected[0]].cam_from_world);
  json common = {{"version", 1},
                 {"mesh", HashFile(asset.mesh)},
                 {"normal_map", asset.normal_map.empty() ? 0 : HashFile(asset.normal_map)},
                 {"support_plane", asset.support_plane.ToJson()},
                 {"format", format.ToJson()},
                 {"intrinsics", ToJson(truth.intrinsics)},
                 {"unit_factor", unit_factor},
                 {"max_depth", settings.max_depth},
                 {"denoise", settings.denoise},
                 {"renderer", RendererFingerprint(scene, probe_camera, ToCueLight(truth.lights[0], unit_factor),
                                                  settings, format)}};
  if (!asset.cue_weights.empty()) common["cue_weights"] = HashFile(asset.cue_weights);  // absent: keys of older caches hold
  return EvalCueCache(root / kEvalCueCacheDir, std::move(common), format);
}

}  // namespace

EvalSummary RunEval(const std::string& workspace, const std::string& truth_json, const std::string& out_dir,
                    const EvalOptions& options, const RenderStageOptions& render, RunRecord& record,
                    const OutputGuard* guard, ModelSet models) {
  CheckOptions(options, "eval");
  CheckOptions(render, "render");
  const fs::path root = fs::absolute(workspace);
  for (const char* file : {"relight/cues/cues.json", "relight/plan/plan.json"}) {
    RELIT_REQUIRE(fs::exists(root / file), "workspace ", workspace, " is not trained: ", (root / file).string(),
                  " is missing (run relit-relight cues, plan and train first)");
  }
  const TruthEvalSet truth = ReadTruthEvalSet(truth_json);
  record.AddInput("truth", truth_json);
  record.AddInput("plan", (root / "relight/plan/plan.json").string());

  // Methods: the final models, the point-light ones when some partition's
  // final model is augmented (a stale augment folder is not), the cue regression.
  const AssetDescription asset = DescribeWorkspace(root.string(), models);
  const AssetDescription point_asset = DescribeWorkspace(root.string(), ModelSet::kPointLight);
  const bool augmented = asset.partition_models != point_asset.partition_models;
  std::vector<std::string> methods, skipped;
  for (const std::string& m : options.methods) {
    (m == "model_point_light" && !augmented ? skipped : methods).push_back(m);
  }
  json skipped_reasons = json::object();
  for (const std::string& m : skipped) {
    skipped_reasons[m] = models == ModelSet::kPointLight
                             ? "augmentation is off (augment.enabled: false): the model is the point-light one"
                             : "no partition has an augmented model of its current point-light model in "
                               "W/relight/augment/";
  }
  // The light input of this workspace (cues.input / cues.bases): the cue
  // frames eval renders must be what the models were trained on.
  const CueFormat format = ReadCuesFile((root / "relight/cues/cues.json").string()).format;
  for (const char* fit : {"cue_fit", "cues_only"}) {
    if (format.is_default() || std::count(methods.begin(), methods.end(), fit) == 0) continue;
    methods.erase(std::find(methods.begin(), methods.end(), fit));
    skipped.push_back(fit);
    skipped_reasons[fit] = "the cue regressions fit the 5 default radiance cues; this workspace's "
                      "cue frames hold " + format.Describe() + " (score it on a default workspace)";
  }
  for (const std::string& m : skipped) spdlog::info("eval: {} skipped ({})", m, skipped_reasons[m].get<std::string>());
  RELIT_REQUIRE(std::any_of(asset.partition_models.begin(), asset.partition_models.end(),
                            [](const std::string& m) { return !m.empty(); }),
                "workspace ", workspace, " is not trained: no partition has train.json (run relit-relight train "
                "--partition K first)");
  std::map<std::string, std::unique_ptr<RelitRenderer>> renderers;
  std::unique_ptr<CuesOnlyBaseline> baseline;
  std::unique_ptr<CueTextureFit> cue_fit;
  bool solve_cue_fit = false;
  std::string cue_fit_source;
  json cue_fit_stats;  // Solve's statistics when solved here
  int baseline_frames = 0;
  // How phone V was linearised: the cue fit's clipping level and the white level below.
  const std::string capture_transfer = CaptureTransfer(root.string());
  const double cue_fit_saturation_level = ResolveSaturationLevel(options.cue_fit.saturation_level, capture_transfer);
  {
    auto timer = record.Time("load");
    for (const std::string& m : methods) {
      if (m == "model") renderers[m] = std::make_unique<RelitRenderer>(asset);
      if (m == "model_point_light") {
        renderers[m] = std::make_unique<RelitRenderer>(point_asset);
      }
    }
    for (const auto& [m, renderer] : renderers) {
      RELIT_REQUIRE(renderer->format() == format, "eval: the ", m, " models read ", renderer->format().Describe(),
                    " but ", (root / "relight/cues/cues.json").string(), " says the cues are ", format.Describe(),
                    ": retrain (relit-relight plan, train) after changing cues.input / cues.bases");
    }
  }
  const bool want_cues_only = std::count(methods.begin(), methods.end(), "cues_only") > 0;
  const bool want_cue_fit = std::count(methods.begin(), methods.end(), "cue_fit") > 0;
  if (want_cues_only || want_cue_fit) {
    auto timer = record.Time("fit_cue_regressions");
    const Plan plan = ReadPlan((root / "relight/plan/plan.json").string());
    if (want_cues_only) baseline = std::make_unique<CuesOnlyBaseline>(options.baseline_resolution_px, options.baseline_ridge);
    if (want_cue_fit) {
      // The model's warm start when it is this very fit (train_stage.h): a
      // minute of solving on the demo saved.
      std::string why_not;
      cue_fit = ReadWarmStartCueFit(root.string(), options.cue_fit, options.cue_fit_resolution_px, &why_not);
      cue_fit_source = cue_fit ? "warm start of partition 00" : "solved here (the warm start: " + why_not + ")";
      spdlog::info("eval: cue_fit {}", cue_fit_source);
      if (!cue_fit) {
        CueFitOptions fit = options.cue_fit;
        fit.saturation_level = cue_fit_saturation_level;
        cue_fit = std::make_unique<CueTextureFit>(options.cue_fit_resolution_px, fit);
        solve_cue_fit = true;
      }
    }
    std::vector<const PlanFrame*> frames;
    for (const PlanFrame& f : plan.frames) {
      if (!f.validation) frames.push_back(&f);
    }
    RELIT_REQUIRE(!frames.empty(), (root / "relight/plan/plan.json").string(), " has no training frame");
    if (baseline || solve_cue_fit) {  // the warm start's fit alone reads no frame
      Progress progress("eval: fit cue regressions", static_cast<int64_t>(frames.size()));
      for (const PlanFrame* f : frames) {
        const Image cues = ReadCueFrame((root / f->cues).string()), image = ReadImage((root / f->image).string()),
                    matte = ReadImage((root / f->matte).string());
        if (baseline) baseline->Accumulate(cues, image, matte);
        if (solve_cue_fit) cue_fit->AddFrame(cues, image, matte);
        progress.Advance();
      }
      progress.Finish();
    }
    if (baseline) baseline->Solve();
    if (solve_cue_fit) cue_fit_stats = cue_fit->Solve().ToJson();
    baseline_frames = static_cast<int>(frames.size());
  }

  // Light units (see eval.h): the cue light stands for the true flash.
  const double unit_factor = asset.flash_intensity / truth.flash_intensity_w_per_sr;
  CueRenderSettings settings;
  settings.samples_per_pixel = options.samples_per_pixel > 0 ? options.samples_per_pixel : render.samples_per_pixel;
  settings.max_depth = asset.cue_max_depth;  // the cues the networks were trained on
  settings.denoise = render.denoise_cues;
  const std::unique_ptr<render::Scene> scene = LoadProxyScene(asset.mesh, asset.support_plane, asset.normal_map, asset.cue_weights);
  const int training_spp = ReadCuesFile((root / "relight/cues/cues.json").string()).samples_per_pixel;
  // More samples than training is fine and better (the demo: 8-spp training
  // cues, eval cues 8 / 32 / 64 spp give 16.49 / 16.64 / 16.76 dB and far
  // less speckle); fewer feeds the networks noise they never saw.
  if (settings.samples_per_pixel < training_spp) {
    spdlog::warn("eval: cue frames at {} spp, fewer than the training cues' {} (noisier cues than the networks "
                 "saw); set eval.samples_per_pixel to {} or more",
                 settings.samples_per_pixel, training_spp, training_spp);
  }
  // The white level: 1 for SDR video (sRGB / gamma 2.2, what relit-synth
  // writes); HDR captures keep highlights above 1, so 1 would be wrong there.
  if ((capture_transfer == "hlg" || capture_transfer == "pq") && options.clip_radiance == 1.0) {
    spdlog::warn("eval: the capture linearised {} video (1 = reference white, highlights above it), but "
                 "eval.clip_radiance is 1: set it to the video's peak in linear units, or 0 for no clip",
                 capture_transfer);
  }
  if (options.clip_radiance > 0) {
    spdlog::info("eval: render and truth clipped to [0, {}] per channel (eval.clip_radiance)", options.clip_radiance);
  }
  // max_views keeps the first N views of each set, so a quick eval still
  // scores interpolation and extrapolation views.
  std::vector<size_t> selected;
  std::map<std::string, int> per_set;
  for (size_t v = 0; v < truth.views.size(); ++v) {
    if (options.max_views == 0 || per_set[truth.views[v].set]++ < options.max_views) selected.push_back(v);
  }
  const size_t view_count = selected.size();

  std::vector<json> light_keys;
  EvalCueCache cue_cache = OpenCueCache(root, options, asset, format, settings, unit_factor, truth, selected,
                                        *scene, &light_keys);

  StageRun out(guard ? AtomicDir(out_dir, *guard) : AtomicDir(out_dir), record);
  std::vector<EvalImageResult> results, floors;
  json zooms = json::array();  // truth | methods strips zoomed on the object, one per image
  Progress progress("eval", static_cast<int64_t>(view_count * truth.lights.size()));
  for (const size_t v : selected) {
    const TruthView& view = truth.views[v];
    const Camera camera(truth.intrinsics, view.cam_from_world);
    const Image matte = ReadImage(view.alpha).SelectChannels(std::vector<int>{0});
    RequireSize(matte, truth.intrinsics, view.alpha);
    const fs::path image_dir = out.path() / "images" / view.name;
    if (options.write_images) fs::create_directories(image_dir);
    for (size_t l = 0; l < truth.lights.size(); ++l) {
      const TruthLight& light = truth.lights[l];
      const std::string gt_path = view.images.at(light.name);
      Image reference = ReadImage(gt_path);
      RELIT_REQUIRE(reference.channels() >= 3, gt_path, " has ", reference.channels(), " channels, expected RGB");
      RequireSize(reference, truth.intrinsics, gt_path);
      reference = Scaled(reference.SelectChannels(std::vector<int>{0, 1, 2}), truth.exposure);
      ClipRadiance(&reference, options.clip_radiance);
      settings.seed = options.seed * 1000003 + v * 1000 + l;
      CueRenderSettings light_settings = settings;
      if (light.type == "environment" && options.environment_samples_per_pixel > 0) {
        light_settings.samples_per_pixel = options.environment_samples_per_pixel;
      }
      Image cues;
      {
        auto timer = record.Time("cues");
        const json key = {{"cam_from_world", ToJson(view.cam_from_world)},
                          {"light", light_keys[l]},
                          {"samples_per_pixel", light_settings.samples_per_pixel},
                          {"seed", light_settings.seed}};
        cues = cue_cache.Get(key, [&] {
          return RenderCueFrame(*scene, camera, ToCueLight(light, unit_factor), light_settings, format);
        });
      }
      if (view.twins.count(light.name) > 0 || view.halves.count(light.name) > 0) {
        floors.push_back(TruthNoiseFloor(view, light, reference, matte, truth, options.clip_radiance));
      }
      const std::string stem = light.name;
      if (options.write_images) WriteReferencePng((image_dir / (stem + "_gt.png")).string(), reference, matte);
      std::vector<Image> predictions;  // per method, for the zoomed comparison
      for (const std::string& method : methods) {
        Image predicted;
        {
          auto timer = record.Time("predict_" + method);
          predicted = method == "cues_only" ? baseline->Predict(cues)
                      : method == "cue_fit" ? cue_fit->Predict(cues)
                                            : renderers.at(method)->RenderCues(cues, camera.Center());
        }
        ClipRadiance(&predicted, options.clip_radiance);
        EvalImageResult r = ResultFor(view, light, method);
        r.metrics = CompareToReference(predicted, reference, matte);
        r.ssim = ForegroundSsim(predicted, reference, matte);
        if (options.write_images) {
          const std::string rel = "images/" + view.name + "/" + stem + "_" + method;
          WriteRenderPng((out.path() / (rel + ".png")).string(), predicted);
          WriteErrorPng((out.path() / (rel + "_error.png")).string(), predicted, reference, matte,
                        options.error_map_scale);
          r.render_png = rel + ".png";
          r.error_png = rel + "_error.png";
          r.reference_png = "images/" + view.name + "/" + stem + "_gt.png";
        }
        spdlog::debug("eval: {} {} {}: PSNR {:.2f} dB, MAE {:.4f}, SSIM {:.3f}", view.name, light.name, method,
                      r.metrics.psnr_db, r.metrics.mae, r.ssim);
        results.push_back(r);
        predictions.push_back(std::move(predicted));
      }
      if (options.write_images) {
        std::vector<const Image*> renders;
        for (const Image& p : predictions) renders.push_back(&p);
        const std::string rel = "images/" + view.name + "/" + stem + "_zoom.png";
        if (WriteZoomStripPng((out.path() / rel).string(), reference, matte, renders)) {
          zooms.push_back({{"view", view.name}, {"view_set", view.set}, {"light", light.name}, {"png", rel},
                           {"columns", [&] {
                              std::vector<std::string> columns = {"truth"};
                              columns.insert(columns.end(), methods.begin(), methods.end());
                              return columns;
                            }()}});
        }
      }
      progress.Advance();
    }
  }
  progress.Finish();
  const int cues_removed = cue_cache.RemoveUnused();
  if (cue_cache.enabled()) {
    spdlog::info("eval: cue frames: {} reused, {} rendered ({}; {} unused removed)", cue_cache.hits(),
                 cue_cache.misses(), (root / kEvalCueCacheDir).string(), cues_removed);
  }

  json header = {
      {"workspace", root.string()},
      {"truth", fs::absolute(truth_json).string()},
      {"methods", methods},
      {"skipped_methods", skipped},
      {"skipped_reasons", skipped_reasons},
      {"model_input", format.ToJson()},
      {"model_variant", ModelVariantLabel(format)},
      {"views", view_count},
      {"lights", truth.lights.size()},
      {"light_unit",
       {{"cue_flash_intensity", asset.flash_intensity},
        {"true_flash_intensity_w_per_sr", truth.flash_intensity_w_per_sr},
        {"factor", unit_factor},
        {"exposure", truth.exposure},
        {"note", "GT light strength S is rendered as S * factor; expected capture value = exposure * GT radiance"}}},
      {"clip_radiance", options.clip_radiance},
      {"capture_transfer", capture_transfer.empty() ? json(nullptr) : json(capture_transfer)},
      {"cues", {{"samples_per_pixel", settings.samples_per_pixel},
                {"training_samples_per_pixel", training_spp},
                {"max_depth", settings.max_depth},
                {"reused", cue_cache.hits()},
                {"rendered", cue_cache.misses()}}},
      {"cues_only", {{"training_frames", baseline_frames},
                     {"resolution_px", options.baseline_resolution_px},
                     {"pixels", baseline ? baseline->pixels_used() : 0}}},
      {"cue_fit", {{"training_frames", baseline_frames},
                   {"resolution_px", options.cue_fit_resolution_px},
                   {"saturation_level", cue_fit_saturation_level},
                   {"source", cue_fit_source},
                   // Solved here: its pixels; the warm start's are in the partition's train.json.
                   {"pixels", solve_cue_fit ? json(cue_fit->pixels()) : json(nullptr)},
                   {"fit", cue_fit_stats}}},
      {"models", asset.partition_models},
      {"zoom_pngs", zooms},
      {"options", OptionsToJson(options)},
      {"timings_s", record.ToJson()["timings_s"]}};
  if (floors.empty()) spdlog::warn("eval: {} lists no noise halves or twins of its images: the truth's noise floor is not "
                                   "measured (render the capture with relit-synth's eval_noise_halves: true)",
                                   truth_json);
  WriteEvalReport(out.path().string(), results, methods, header, floors);
  record.Set("images", static_cast<int>(view_count * truth.lights.size()));
  record.Set("methods", methods);
  out.Commit();
  spdlog::info("eval: {} images x {} methods scored into {}", view_count * truth.lights.size(), methods.size(),
               out.target().string());
  EvalSummary summary;
  summary.out_dir = out.target().string();
  summary.images = static_cast<int>(view_count * truth.lights.size());
  summary.methods = methods;
  return summary;
}

}  // namespace relit::relight
