#include "relight/augment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"
#include "core/progress.h"
#include "core/render/envmaps.h"
#include "core/run_record.h"
#include "relight/asset.h"
#include "relight/checkpoint.h"
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/plan.h"
#include "relight/render_stage.h"
#include "relight/train_loop.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;




namespace {

struct AugmentMap {
  std::string name;
  render::EnvironmentLight light;  // normalised (scale applied)
};

double MeanRadiance(const Image& map) {
  double sum = 0, weight = 0;
  for (int y = 0; y < map.height(); ++y) {
    const double w = std::sin(M_PI * (y + 0.5) / map.height());
    for (int x = 0; x < map.width(); ++x) {
      const float* p = map.pixel(x, y);
      sum += w * (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]);
      weight += w;
    }
  }
  return sum / weight;
}

// The procedural maps, then the user's (sorted by file name), each scaled to
// the target irradiance.
std::vector<AugmentMap> LoadMaps(const AugmentOptions& options, double irradiance) {
  std::vector<std::pair<std::string, Image>> raw;
  for (int i = 0; i < options.maps; ++i) {
    render::ProceduralEnvironment env = render::MakeAugmentationMap(options.map_width_px, options.seed, i);
    raw.emplace_back(env.name, std::move(env.map));
  }
  if (!options.map_dir.empty()) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(options.map_dir)) {
      std::string ext = entry.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
      if (ext == ".exr" || ext == ".hdr") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    RELIT_REQUIRE(!files.empty(), "augment.map_dir ", options.map_dir, " holds no .exr or .hdr file");
    for (const fs::path& file : files) {
      Image map = ReadImage(file.string());
      RELIT_REQUIRE(map.channels() >= 3 && map.width() == 2 * map.height(), file.string(),
                    ": an environment map must be equirectangular RGB (width = 2 x height), got ", map.width(),
                    "x", map.height(), "x", map.channels());
      raw.emplace_back("file_" + file.stem().string(), std::move(map));
    }
  }
  RELIT_REQUIRE(!raw.empty(), "augment: no environment map (augment.maps is 0 and no augment.map_dir)");
  std::vector<AugmentMap> maps;
  for (auto& [name, image] : raw) {
    const double mean = MeanRadiance(image);
    RELIT_REQUIRE(mean > 0 && std::isfinite(mean), "augment: environment map ", name, " is black or not finite");
    maps.push_back({name, render::EnvironmentLight(image, static_cast<float>(irradiance / (M_PI * mean)))});
  }
  return maps;
}

std::vector<Eigen::Vector3d> FibonacciDirections(int count) {
  std::vector<Eigen::Vector3d> directions;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1 - 2 * (i + 0.5) / count, r = std::sqrt(std::max(0.0, 1 - z * z));
    directions.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return directions;
}

// RGB irradiance of `map` gathered over each direction's Voronoi cell.
std::vector<Eigen::Vector3d> CellIrradiance(const render::EnvironmentLight& light,
                                            const std::vector<Eigen::Vector3d>& directions) {
  std::vector<Eigen::Vector3d> cells(directions.size(), Eigen::Vector3d::Zero());
  const int width = light.map().width(), height = light.map().height();
  for (int y = 0; y < height; ++y) {
    const double solid_angle = (2 * M_PI / width) * (M_PI / height) * std::sin(M_PI * (y + 0.5) / height);
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d d = render::EnvironmentPixelDirection(x, y, width, height);
      size_t best = 0;
      for (size_t k = 1; k < directions.size(); ++k) {
        if (directions[k].dot(d) > directions[best].dot(d)) best = k;
      }
      const render::Rgb radiance = light.Eval(d.cast<float>());
      cells[best] += solid_angle * radiance.cast<double>().matrix();
    }
  }
  return cells;
}

// Directions and per-map RGB weights (irradiance of each directional light).
struct LightSplit {
  std::vector<Eigen::Vector3d> directions;
  std::vector<std::vector<Eigen::Vector3d>> weights;  // [map in the view][direction]
};

LightSplit ImportanceSplit(const std::vector<const AugmentMap*>& maps, int count, render::Rng& rng) {
  LightSplit split;
  split.weights.assign(maps.size(), {});
  for (int k = 0; k < count; ++k) {
    float pdf = 0;
    const render::Vec3f d = maps[k % maps.size()]->light.Sample(rng.Uniform2(), &pdf);
    double mixture = 0;
    for (const AugmentMap* m : maps) mixture += m->light.Pdf(d) / maps.size();
    split.directions.push_back(d.cast<double>());
    for (size_t m = 0; m < maps.size(); ++m) {
      const Eigen::Vector3d radiance = maps[m]->light.Eval(d).cast<double>().matrix();
      split.weights[m].push_back(mixture > 0 ? Eigen::Vector3d(radiance / (count * mixture))
                                             : Eigen::Vector3d::Zero());
    }
  }
  return split;
}

std::string FrameStem(const std::string& frame_name, const std::string& map_name) {
  std::string stem = frame_name;
  std::replace(stem.begin(), stem.end(), '/', '_');
  return stem + "__" + map_name;
}

Intrinsics ScaledCamera(const Intrinsics& camera, double scale) {
  auto multiple_of_4 = [&](int size) { return std::max(4, static_cast<int>(std::lround(size * scale / 4.0)) * 4); };
  return scale >= 1.0 ? camera : camera.Scaled(multiple_of_4(camera.width), multiple_of_4(camera.height));
}

// The window of an image, or an image pasted into a larger one.
struct Window {
  int x0 = 0, y0 = 0, width = 0, height = 0;
};

Image CropImage(const Image& image, const Window& w) {
  Image out(w.width, w.height, image.channel_names());
  for (int y = 0; y < w.height; ++y) {
    std::copy_n(image.pixel(w.x0, w.y0 + y), static_cast<size_t>(w.width) * image.channels(), out.pixel(0, y));
  }
  return out;
}

// The proxy's bounding box in a cue frame (coverage > 0), grown by `margin`
// pixels and to multiples of 4: the networks only need to run there.
Window CoverageWindow(const Image& cue_frame, int margin) {
  const int a = cue_frame.ChannelIndex("A");
  int x_min = cue_frame.width(), y_min = cue_frame.height(), x_max = -1, y_max = -1;
  for (int y = 0; y < cue_frame.height(); ++y) {
    for (int x = 0; x < cue_frame.width(); ++x) {
      if (cue_frame.at(x, y, a) <= 0) continue;
      x_min = std::min(x_min, x), x_max = std::max(x_max, x);
      y_min = std::min(y_min, y), y_max = std::max(y_max, y);
    }
  }
  if (x_max < 0) return {0, 0, cue_frame.width(), cue_frame.height()};
  auto span = [&](int lo, int hi, int size, int* start, int* length) {
    lo = std::max(0, lo - margin);
    hi = std::min(size - 1, hi + margin);
    *length = std::min(size, ((hi - lo + 1 + 3) / 4) * 4);
    *start = std::clamp(lo, 0, size - *length);
  };
  Window w;
  span(x_min, x_max, cue_frame.width(), &w.x0, &w.width);
  span(y_min, y_max, cue_frame.height(), &w.y0, &w.height);
  return w;
}

// Renders the augmented frames of one view (maps x (cues, target)).
void AugmentView(RelitRenderer& renderer, const Camera& camera, const std::vector<const AugmentMap*>& maps,
                 const LightSplit& split, const AugmentOptions& options, double reference_irradiance,
                 int cue_max_depth, uint64_t seed, const std::vector<fs::path>& stems) {
  CueRenderSettings settings{options.samples_per_pixel, cue_max_depth, seed};
  const int width = camera.intrinsics().width, height = camera.intrinsics().height;
  std::vector<Image> targets(maps.size(), Image(width, height, std::vector<std::string>{"R", "G", "B"}));
  Image alpha;
  Window window;
  for (size_t k = 0; k < split.directions.size(); ++k) {
    bool lit = false;
    for (const auto& w : split.weights) lit = lit || w[k].maxCoeff() > 0;
    if (!lit && !alpha.empty()) continue;
    // Each directional light shines as bright as the flash on the object
    // (the networks' training range) and its output is scaled to its weight:
    // a dim light would probe the networks where they never learnt.
    CueLight light;
    light.kind = CueLight::Kind::kDirectional;
    light.direction_to_light = split.directions[k].normalized();
    light.color = Eigen::Vector3d::Constant(reference_irradiance);
    settings.seed = seed * 1000003 + k;
    const Image cue_frame = RenderCueFrame(renderer.scene(), camera, light, settings, renderer.format());
    if (alpha.empty()) {
      window = CoverageWindow(cue_frame, 16);  // the same for every light
      alpha = Image(width, height, std::vector<std::string>{"A"});
    }
    const Image rgba = renderer.RenderCues(CropImage(cue_frame, window), camera.Center());
    for (int y = 0; y < window.height; ++y) {
      for (int x = 0; x < window.width; ++x) {
        const float* in = rgba.pixel(x, y);
        alpha.at(window.x0 + x, window.y0 + y, 0) = in[3];
        for (size_t m = 0; m < maps.size(); ++m) {
          const Eigen::Vector3d w = split.weights[m][k] / reference_irradiance;
          float* out = targets[m].pixel(window.x0 + x, window.y0 + y);
          for (int c = 0; c < 3; ++c) out[c] += static_cast<float>(w[c]) * in[c];
        }
      }
    }
  }
  for (size_t m = 0; m < maps.size(); ++m) {
    CueLight light;
    light.kind = CueLight::Kind::kEnvironment;
    light.environment = maps[m]->light;
    settings.seed = seed * 1000003 + 999983 + m;
    settings.samples_per_pixel = options.map_samples_per_pixel;
    WriteImage(stems[m].string() + ".cues.exr",
               RenderCueFrame(renderer.scene(), camera, light, settings, renderer.format()));
    // Straight colour (the model's targets are unpremultiplied) + the mask network's alpha.
    Image target(width, height, std::vector<std::string>{"R", "G", "B", "A"});
    for (size_t p = 0; p < target.pixel_count(); ++p) {
      const float a = alpha.data()[p];
      for (int c = 0; c < 3; ++c) target.data()[4 * p + c] = a > 1e-3f ? targets[m].data()[3 * p + c] / a : 0.0f;
      target.data()[4 * p + 3] = a;
    }
    WriteImage(stems[m].string() + ".target.exr", target);  // written last: the pair is complete
  }
}

Batch LoadAugmentedFrame(const fs::path& stem, const CueFormat& format) {
  Batch batch = CueFrameToBatch(ReadCueFrame(stem.string() + ".cues.exr", format), format);
  const Image target = ReadImage(stem.string() + ".target.exr");
  RELIT_REQUIRE(target.channels() == 4 && target.width() == batch.width() && target.height() == batch.height(),
                stem.string(), ".target.exr: expected RGBA of the cue frame's size; delete the augment folder");
  AttachTargets(batch, target, target, 3);  // RGB + matte in A
  return batch;
}

std::string Hash(const std::string& path) { return std::to_string(HashFile(path)); }

// The fingerprint's "source": the point-light model a partition's augment
// folder is fine-tuned from.
std::string SourceHash(const fs::path& point_dir) { return Hash((point_dir / "checkpoint" / "model.pt").string()); }

// A fingerprint file, or null when missing or unreadable.
json ReadFingerprint(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return json();
  json j = json::parse(in, nullptr, false);
  return j.is_discarded() ? json() : j;
}

}  // namespace

bool AugmentedFromCurrentModel(const std::string& augment_dir, const std::string& point_dir) {
  const json previous = ReadFingerprint(fs::path(augment_dir) / "fingerprint.json");
  if (!previous.is_object() || !previous.contains("inputs") || !previous["inputs"].is_object()) return false;
  return fs::exists(fs::path(point_dir) / "checkpoint" / "model.pt") &&
         previous["inputs"].value("source", std::string()) == SourceHash(point_dir);
}

AugmentStageResult RunAugmentStage(const std::string& workspace, int partition, const AugmentOptions& options,
                                   const TrainStageOptions& train, bool restart, RunRecord& record) {
  CheckOptions(options, "augment");
  const fs::path root = fs::absolute(workspace);
  const std::string plan_path = (root / "relight" / "plan" / "plan.json").string();
  const Plan plan = ReadPlan(plan_path);
  RELIT_REQUIRE(partition >= 0 && partition < static_cast<int>(plan.partitions.size()), "partition ", partition,
                " does not exist: the plan (", plan_path, ") has partitions 0..", plan.partitions.size() - 1);
  const PlanPartition& part = plan.partitions[partition];
  const std::string name = PartitionDirName(partition);
  const fs::path dir = root / "relight" / "augment" / name, frames_dir = dir / "frames";
  const fs::path source = root / "relight" / "partitions" / name;
  const fs::path done_path = dir / "train.json", log_path = dir / "log.jsonl", checkpoint_dir = dir / "checkpoint";
  if (restart) fs::remove_all(dir);
  fs::create_directories(frames_dir);
  fs::remove(done_path);
  record.Set("partition", partition);
  AugmentStageResult result;
  if (part.train_frames.empty()) {
    result.skipped = true;
    record.Set("skipped", "the partition has no training frame");
    record.Write(done_path.string());
    return result;
  }
  RELIT_REQUIRE(fs::exists(source / "train.json") && fs::exists(source / "checkpoint" / "checkpoint.json"),
                "augment: partition ", partition, " has no trained point-light model in ", source.string(),
                ": run `relit-relight train --partition ", partition, "` first");

  // Everything the augmented frames depend on: a change regenerates them all.
  const std::string cues_path = (root / "relight" / "cues" / "cues.json").string();
  const CuesFile cues = ReadCuesFile(cues_path);
  const AssetDescription point_asset = DescribeWorkspace(root.string(), ModelSet::kPointLight);
  json frames_fingerprint = {{"cues", Hash(cues_path)}, {"plan", Hash(plan_path)}, {"options", OptionsToJson(options)}};
  for (const std::string& model : point_asset.partition_models) {
    frames_fingerprint["models"].push_back(model.empty() ? "" : Hash(model + "/model.pt"));
  }
  frames_fingerprint["options"].erase("steps");
  frames_fingerprint["options"].erase("checkpoint_every");
  frames_fingerprint["options"].erase("log_every");
  frames_fingerprint["options"].erase("enabled");
  const fs::path frames_fingerprint_path = frames_dir / "fingerprint.json";
  if (ReadFingerprint(frames_fingerprint_path) != frames_fingerprint) {
    fs::remove_all(frames_dir);
    fs::remove_all(checkpoint_dir);
    fs::create_directories(frames_dir);
    AtomicWriteFile(frames_fingerprint_path, frames_fingerprint.dump(2));
  }

  // The views: an even spread over the partition's training frames.
  std::vector<int> views;
  const int count = options.views > 0 ? std::min<int>(options.views, part.train_frames.size())
                                      : static_cast<int>(part.train_frames.size());
  for (int i = 0; i < count; ++i) views.push_back(part.train_frames[part.train_frames.size() * (2 * i + 1) / (2 * count)]);
  std::map<std::string, const CueFrameRecord*> records;
  for (const CueFrameRecord& r : cues.frames) records[r.name] = &r;

  // The flash's irradiance on the object at the capture distance (cue units).
  const double flash_irradiance =
      cues.flash_intensity / (point_asset.capture_distance_m * point_asset.capture_distance_m);
  const double irradiance = options.exposure * flash_irradiance;
  std::vector<fs::path> stems_all;
  {
    auto timer = record.Time("augment_frames");
    const std::vector<AugmentMap> maps = LoadMaps(options, irradiance);  // names even when frames are reused
    std::optional<RelitRenderer> renderer;
    std::vector<Eigen::Vector3d> fixed_directions;
    std::map<int, std::vector<Eigen::Vector3d>> cell_weights;  // "all" mode, per map index
    Progress progress("augment views, partition " + name, static_cast<int64_t>(views.size()));
    for (size_t v = 0; v < views.size(); ++v) {
      const PlanFrame& frame = plan.frames[views[v]];
      // Maps drawn for this view: a pure function of (seed, view).
      render::Rng rng(options.seed, 7000 + static_cast<uint64_t>(views[v]));
      std::vector<int> order(maps.size());
      for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
      const int drawn = std::min<int>(options.maps_per_view, maps.size());
      for (int i = 0; i < drawn; ++i) std::swap(order[i], order[i + static_cast<int>(rng.Uniform() * (order.size() - i))]);
      std::vector<const AugmentMap*> view_maps;
      std::vector<fs::path> stems;
      bool complete = true;
      for (int i = 0; i < drawn; ++i) {
        view_maps.push_back(&maps[order[i]]);
        stems.push_back(frames_dir / FrameStem(frame.name, maps[order[i]].name));
        complete = complete && fs::exists(stems.back().string() + ".target.exr");
      }
      stems_all.insert(stems_all.end(), stems.begin(), stems.end());
      if (complete) {
        progress.Advance();
        continue;
      }
      if (!renderer) renderer.emplace(point_asset);
      const auto record_it = records.find(frame.name);
      RELIT_REQUIRE(record_it != records.end(), "augment: frame ", frame.name, " of the plan is not in ", cues_path,
                    "; rerun `relit-relight plan`");
      const Camera camera(ScaledCamera(cues.camera, options.resolution_scale), record_it->second->cam_from_world);
      LightSplit split;
      if (options.sampling == "importance") {
        split = ImportanceSplit(view_maps, options.directions, rng);
      } else {
        if (fixed_directions.empty()) fixed_directions = FibonacciDirections(options.directions);
        split.directions = fixed_directions;
        for (int i = 0; i < drawn; ++i) {
          if (!cell_weights.count(order[i])) cell_weights[order[i]] = CellIrradiance(maps[order[i]].light, fixed_directions);
          split.weights.push_back(cell_weights[order[i]]);
        }
      }
      AugmentView(*renderer, camera, view_maps, split, options, flash_irradiance, point_asset.cue_max_depth,
                  options.seed * 7919 + static_cast<uint64_t>(views[v]), stems);
      progress.Advance();
    }
    progress.Finish();
  }
  result.views = static_cast<int>(views.size());
  result.frames = static_cast<int>(stems_all.size());

  // Fine-tuning from the point-light checkpoint.
  const json fingerprint = {{"frames", frames_fingerprint}, {"source", SourceHash(source)},
                            {"train", OptionsToJson(train.optimizer)}};
  const fs::path fingerprint_path = dir / "fingerprint.json";
  std::unique_ptr<Trainer> trainer;
  int64_t start_step = 0;
  if (fs::exists(checkpoint_dir / "checkpoint.json") && fs::exists(fingerprint_path)) {
    const json previous = ReadFingerprint(fingerprint_path);
    if (previous.is_object() && previous.value("inputs", json()) == fingerprint) {
      trainer = LoadTrainer(checkpoint_dir);
      start_step = previous.value("start_step", int64_t{0});
      result.resumed_from = trainer->step();
      spdlog::info("augment: partition {} continues from its checkpoint at step {}", partition, trainer->step());
    }
  }
  if (!trainer) {
    fs::remove_all(checkpoint_dir);
    fs::remove(log_path);
    trainer = LoadTrainer(source / "checkpoint");
    start_step = trainer->step();
    AtomicWriteFile(fingerprint_path, json{{"inputs", fingerprint}, {"start_step", start_step}}.dump(2));
  } else {
    TruncateLog(log_path, trainer->step());
  }

  const CueFormat format = trainer->model()->options().format;
  std::vector<Batch> captured, augmented, validation;
  {
    auto timer = record.Time("load_frames");
    Progress progress("load frames", static_cast<int64_t>(part.train_frames.size() + stems_all.size()));
    for (int index : part.train_frames) {
      captured.push_back(LoadPlanFrame(root.string(), plan.frames[index], format));
      progress.Advance();
    }
    for (const fs::path& stem : stems_all) {
      augmented.push_back(LoadAugmentedFrame(stem, format));
      progress.Advance();
    }
    progress.Finish();
    ThresholdMattes(captured, train.optimizer.matte_threshold);
    validation = LoadValidationFrames(root.string(), plan, part, train.max_validation_frames, format,
                                      train.optimizer.matte_threshold);
  }
  if (!validation.empty()) {
    DnlModel model = LoadModel(source / "checkpoint");
    result.val_psnr_before_db = Validate(model, validation).psnr_db;
  }
  FrameOrder captured_order(static_cast<int>(captured.size()), train.optimizer.seed);
  FrameOrder augmented_order(static_cast<int>(augmented.size()), train.optimizer.seed + 1);
  TrainLoopSettings settings;
  settings.label = "augment partition " + name;
  settings.total_steps = start_step + options.steps;
  settings.checkpoint_every = options.checkpoint_every;
  settings.log_every = options.log_every;
  settings.checkpoint_dir = checkpoint_dir;
  settings.log_path = log_path;
  const auto start = std::chrono::steady_clock::now();
  TrainLoopResult loop;
  {
    auto timer = record.Time("fine_tune");
    // Alternating steps: even = a captured frame, odd = an augmented one.
    loop = RunTrainLoop(
        *trainer,
        [&](int64_t step) {
          const int64_t i = step - start_step;
          return i % 2 == 0 ? captured[captured_order.At(i / 2)] : augmented[augmented_order.At(i / 2)];
        },
        validation, settings, [&](int64_t step) { return (step - start_step) % 2 == 0 ? "captured" : "augmented"; });
  }
  result.steps = trainer->step();
  if (loop.interrupted) {
    result.interrupted = true;
    spdlog::warn("augment: partition {} stopped by signal {} at step {}; checkpoint saved, rerun to continue",
                 partition, loop.signal, result.steps);
    return result;
  }
  result.val_psnr_after_db = loop.validation.psnr_db;
  const double seconds = SecondsSince(start);
  record.Set("views", result.views);
  record.Set("augmented_frames", result.frames);
  record.Set("captured_frames", static_cast<int>(captured.size()));
  record.Set("maps", options.maps);
  record.Set("map_irradiance", irradiance);
  record.Set("start_step", start_step);
  record.Set("steps", result.steps);
  record.Set("resumed_from_step", result.resumed_from);
  record.Set("final_loss", loop.final_loss);
  if (!validation.empty()) {
    record.Set("val_psnr_before_db", result.val_psnr_before_db);
    record.Set("val_psnr_after_db", result.val_psnr_after_db);
  }
  const int64_t trained = result.steps - std::max(result.resumed_from, start_step);
  record.Set("seconds_per_step", trained > 0 ? seconds / trained : 0.0);
  record.Set("process_cpu_s", ProcessCpuSeconds());  // frames, fine-tuning; this run only
  record.Write(done_path.string());
  spdlog::info("augment: partition {} done: {} views x {} maps, {} fine-tuning steps{}", partition, result.views,
               options.maps_per_view, options.steps,
               validation.empty() ? std::string()
                                  : fmt::format(", captured-frame validation PSNR {:.2f} -> {:.2f} dB",
                                                result.val_psnr_before_db, result.val_psnr_after_db));
  return result;
}

}  // namespace relit::relight
