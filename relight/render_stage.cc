#include "relight/render_stage.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/color.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/render/envmaps.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "core/workspace.h"
#include "core/stage_run.h"
#include "relight/checkpoint.h"
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/train_stage.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

RelitRenderer::RelitRenderer(const AssetDescription& asset, const std::string& device)
    : asset_(asset), layout_(asset.Layout()) {
  RELIT_REQUIRE(static_cast<int>(asset_.partition_models.size()) == layout_.partition_count(),
                "asset: ", asset_.partition_models.size(), " partitions listed, the layout has ",
                layout_.partition_count());
  scene_ = LoadProxyScene(asset_.mesh, asset_.support_plane, asset_.normal_map, asset_.cue_weights);
  models_.resize(asset_.partition_models.size());
  int loaded = 0;
  for (size_t p = 0; p < asset_.partition_models.size(); ++p) {
    if (asset_.partition_models[p].empty()) continue;
    models_[p] = LoadModel(asset_.partition_models[p], device);
    const CueFormat& format = (*models_[p])->options().format;
    RELIT_REQUIRE(loaded == 0 || format == format_, "partition ", p, " (", asset_.partition_models[p],
                  ") was trained on ", format.Describe(), ", an earlier partition on ", format_.Describe(),
                  ": retrain the partitions with one config");
    format_ = format;
    ++loaded;
  }
  RELIT_REQUIRE(loaded > 0, "no trained partition to render with: run `relit-relight train --partition K` "
                "for the plan's partitions first");
  spdlog::info("render: {} of {} partitions trained", loaded, asset_.partition_models.size());
}

std::vector<std::pair<int, double>> RelitRenderer::Weights(const Eigen::Vector3d& direction) const {
  const PartitionBlend blend = layout_.Blend(direction);
  std::vector<std::pair<int, double>> weights;
  double total = 0;
  for (int i = 0; i < blend.count; ++i) {
    if (blend.weight[i] > 0 && models_[blend.partition[i]]) {
      weights.emplace_back(blend.partition[i], blend.weight[i]);
      total += blend.weight[i];
    }
  }
  if (weights.empty()) {
    // No trained partition around this direction: the nearest trained vertex.
    int best = -1;
    double best_dot = -2;
    for (size_t p = 0; p < models_.size(); ++p) {
      const double dot = layout_.vertices()[p].dot(direction.normalized());
      if (models_[p] && dot > best_dot) {
        best_dot = dot;
        best = static_cast<int>(p);
      }
    }
    return {{best, 1.0}};
  }
  for (auto& [p, w] : weights) w /= total;
  return weights;
}

Image RelitRenderer::Render(const Camera& camera, const CueLight& light, const CueRenderSettings& settings_in) {
  CueRenderSettings settings = settings_in;
  settings.max_depth = asset_.cue_max_depth;  // new views see the cues the networks were trained on
  return RenderCues(RenderCueFrame(*scene_, camera, light, settings, format_), camera.Center());
}

Image RelitRenderer::RenderCues(const Image& cue_frame, const Eigen::Vector3d& camera_centre_m) {
  const Batch batch = CueFrameToBatch(cue_frame, format_);
  Image result(cue_frame.width(), cue_frame.height(), {"R", "G", "B", "A"});
  for (const auto& [partition, weight] : Weights(camera_centre_m - asset_.object_centre_m)) {
    const Image rgba = RenderFrame(*models_[partition], batch);
    for (size_t i = 0; i < result.data().size(); ++i) result.data()[i] += static_cast<float>(weight) * rgba.data()[i];
  }
  return result;
}

namespace {

Eigen::Vector3d ColorFromJson(const json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key)) return Eigen::Vector3d::Ones();
  const json& v = j[key];
  if (v.is_number()) return Eigen::Vector3d::Constant(v.get<double>());
  return Vector3FromJson(v, where + "." + key);
}

render::EnvironmentLight LoadEnvironment(const std::string& map, double scale, double rotation_rad,
                                         const std::string& base_dir) {
  if (map.empty() || map == "procedural:sky") {
    return render::EnvironmentLight(render::MakeSkyMap(512, 35.0 * M_PI / 180, 40.0 * M_PI / 180),
                                    static_cast<float>(scale), static_cast<float>(rotation_rad));
  }
  if (map == "procedural:studio") {
    return render::EnvironmentLight(render::MakeStudioMap(512), static_cast<float>(scale),
                                    static_cast<float>(rotation_rad));
  }
  const fs::path path = fs::path(map).is_absolute() ? fs::path(map) : fs::path(base_dir) / map;
  RELIT_REQUIRE(fs::exists(path), "environment map ", path.string(), " does not exist");
  return render::EnvironmentLight::FromFile(path.string(), static_cast<float>(scale),
                                            static_cast<float>(rotation_rad));
}

// Sphere point at elevation/azimuth around the object, looking at its centre.
Camera TurntableCamera(const Intrinsics& intrinsics, const Eigen::Vector3d& centre, double distance_m,
                       double elevation_rad, double azimuth_rad) {
  const Eigen::Vector3d direction(std::cos(elevation_rad) * std::cos(azimuth_rad),
                                  std::cos(elevation_rad) * std::sin(azimuth_rad), std::sin(elevation_rad));
  return Camera(intrinsics, LookAt(centre + distance_m * direction, centre, Eigen::Vector3d::UnitZ()));
}

void EncodeMp4(const fs::path& frames_dir, const fs::path& mp4, double fps, int width, int height) {
  // MP4 has no alpha: composite the straight-alpha PNGs over mid grey.
  const std::string command =
      "ffmpeg -nostdin -y -loglevel error -framerate " + std::to_string(fps) + " -i " +
      ShellQuote((frames_dir / "%04d.png").string()) + " -filter_complex " +
      ShellQuote("color=c=0x404040:s=" + std::to_string(width) + "x" + std::to_string(height) +
                 "[bg];[bg][0:v]overlay=shortest=1,format=yuv420p") +
      " -c:v libx264 -crf 18 " + ShellQuote(mp4.string());
  const CommandResult result = RunCommand(command);
  RELIT_REQUIRE(result.ok(), "ffmpeg ", ExitDescription(result.status), " while encoding ", mp4.string(), ": ",
                result.ErrTail());
}

}  // namespace

namespace {

// A light's colour or strength: finite and not negative (a negative light
// would subtract radiance).
Eigen::Vector3d PowerFromJson(const json& j, const std::string& key, const std::string& where) {
  const Eigen::Vector3d c = ColorFromJson(j, key, where);
  RELIT_REQUIRE(c.allFinite() && (c.array() >= 0).all(), where, ".", key, ": must be finite and >= 0, got [",
                c.x(), ", ", c.y(), ", ", c.z(), "]; give the light's strength as a positive number or RGB triple");
  return c;
}

Eigen::Vector3d FiniteVector(const json& j, const std::string& key, const std::string& where) {
  const Eigen::Vector3d v = Vector3FromJson(JsonField(j, key, where), where + "." + key);
  RELIT_REQUIRE(v.allFinite(), where, ".", key, ": must be three finite numbers");
  return v;
}

}  // namespace

CueLight LightFromJson(const json& j, const std::string& base_dir, const std::string& where) {
  RELIT_REQUIRE(j.is_object(), where, ": expected an object with a \"type\" (point, directional, environment, area)");
  const json& type_json = JsonField(j, "type", where);
  RELIT_REQUIRE(type_json.is_string(), where, ".type: expected a string (point, directional, environment, area)");
  const std::string type = type_json.get<std::string>();
  CueLight light;
  if (type == "point") {
    light.kind = CueLight::Kind::kPoint;
    light.position_m = FiniteVector(j, "position_m", where);
    light.color = PowerFromJson(j, "intensity", where);
  } else if (type == "directional") {
    light.kind = CueLight::Kind::kDirectional;
    const Eigen::Vector3d direction = FiniteVector(j, "direction_to_light", where);
    RELIT_REQUIRE(direction.norm() > 1e-9, where, ".direction_to_light: is zero; give the direction towards the "
                  "light, e.g. [0, 0, 1] for a light straight above");
    light.direction_to_light = direction.normalized();
    light.color = PowerFromJson(j, "irradiance", where);
  } else if (type == "environment") {
    light.kind = CueLight::Kind::kEnvironment;
    const double scale = j.contains("scale") && j["scale"].is_number() ? j["scale"].get<double>() : 1.0;
    RELIT_REQUIRE(std::isfinite(scale) && scale >= 0 && (!j.contains("scale") || j["scale"].is_number()), where,
                  ".scale: must be a finite number >= 0");
    RELIT_REQUIRE(!j.contains("map") || j["map"].is_string(), where, ".map: expected a file name or procedural:sky");
    RELIT_REQUIRE(!j.contains("rotation_deg") || j["rotation_deg"].is_number(), where,
                  ".rotation_deg: expected a number");
    light.environment = LoadEnvironment(j.value("map", std::string()), scale,
                                        j.value("rotation_deg", 0.0) * M_PI / 180, base_dir);
  } else if (type == "area") {
    light.kind = CueLight::Kind::kQuad;
    light.quad.corner = FiniteVector(j, "corner_m", where).cast<float>();
    const Eigen::Vector3d u = FiniteVector(j, "edge_u_m", where), v = FiniteVector(j, "edge_v_m", where);
    RELIT_REQUIRE(u.cross(v).norm() > 1e-12, where, ": edge_u_m and edge_v_m span no area; give two "
                  "non-parallel, non-zero edges");
    light.quad.edge_u = u.cast<float>();
    light.quad.edge_v = v.cast<float>();
    light.quad.radiance = PowerFromJson(j, "radiance", where).cast<float>().array();
  } else {
    Fail(where, ": light type must be point, directional, environment or area, got '", type, "'");
  }
  return light;
}

void WriteRgba(const std::string& path_without_extension, const Image& rgba) {
  WriteImage(path_without_extension + ".exr", rgba);
  Image png(rgba.width(), rgba.height(), {"R", "G", "B", "A"});
  for (int y = 0; y < rgba.height(); ++y) {
    for (int x = 0; x < rgba.width(); ++x) {
      const float* p = rgba.pixel(x, y);
      float* o = png.pixel(x, y);
      const float a = std::clamp(p[3], 0.0f, 1.0f);
      for (int c = 0; c < 3; ++c) o[c] = a > 1e-6f ? LinearToSrgb(std::clamp(p[c] / a, 0.0f, 1.0f)) : 0.0f;
      o[3] = a;
    }
  }
  WriteImage(path_without_extension + ".png", png, PixelStorage::kUint8);
}

void RunRenderStage(const std::string& workspace, const RenderStageOptions& options, RunRecord& record,
                    ModelSet models) {
  CheckOptions(options, "render");
  const AssetDescription asset = DescribeWorkspace(workspace, models);
  RelitRenderer renderer(asset);
  const Intrinsics intrinsics =
      options.width_px > 0 ? asset.camera.Scaled(options.width_px, options.height_px) : asset.camera;
  const double distance =
      options.distance_scale > 0 ? options.distance_scale * asset.object_radius_m : asset.capture_distance_m;
  CueRenderSettings settings;
  settings.samples_per_pixel = options.samples_per_pixel;
  settings.denoise = options.denoise_cues;
  StageRun out(AtomicDir(fs::path(workspace) / "relight" / "render"), record, "render.json");
  const double flash = asset.flash_intensity;
  const render::EnvironmentLight environment =
      LoadEnvironment(options.environment_map, options.environment_scale * flash, 0.0, workspace);
  json turntables = json::object();
  for (const std::string kind : {"point", "env"}) {
    const fs::path dir = out.path() / ("turntable_" + kind);
    fs::create_directories(dir);
    auto timer = record.Time("turntable_" + kind);
    Progress progress("render turntable (" + kind + ")", options.frames);
    for (int i = 0; i < options.frames; ++i) {
      const double azimuth = 2 * M_PI * i / options.frames;
      const Camera camera =
          TurntableCamera(intrinsics, asset.object_centre_m, distance, options.elevation_deg * M_PI / 180, azimuth);
      CueLight light;
      if (kind == "point") {
        const Eigen::Vector3d offset(options.point_light_offset_m[0], options.point_light_offset_m[1],
                                     options.point_light_offset_m[2]);
        light = CueLight::Point(camera.world_from_cam() * offset, options.point_light_intensity * flash);
      } else {
        light.kind = CueLight::Kind::kEnvironment;
        light.environment = environment;
      }
      settings.seed = 7000 + i;
      char name[16];
      std::snprintf(name, sizeof(name), "%04d", i);
      WriteRgba((dir / name).string(), renderer.Render(camera, light, settings));
      progress.Advance();
    }
    progress.Finish();
    json entry = {{"frames", options.frames}, {"folder", "turntable_" + kind}};
    if (options.write_mp4) {
      EncodeMp4(dir, out.path() / ("turntable_" + kind + ".mp4"), options.fps, intrinsics.width, intrinsics.height);
      entry["mp4"] = "turntable_" + kind + ".mp4";
    }
    turntables[kind] = entry;
  }
  record.Set("turntables", turntables);
  record.Set("distance_m", distance);
  out.Commit();
  spdlog::info("render: turntables written to {}", out.target().string());
}

void RunRenderViews(const AssetDescription& asset, const std::string& views_json, const std::string& out_dir,
                    const RenderStageOptions& options, RunRecord& record, const std::string& device, bool force) {
  std::ifstream in(views_json);
  RELIT_REQUIRE(in, "cannot read ", views_json);
  const json views = json::parse(in, nullptr, false);
  RELIT_REQUIRE(!views.is_discarded() && views.is_object() && views.contains("views") && views["views"].is_array(),
                views_json, ": expected a JSON object with a \"views\" array (docs/relight.md)");
  RELIT_REQUIRE(!views["views"].empty(), views_json,
                ": the \"views\" array is empty; add at least one view (docs/relight.md)");
  const std::string base = fs::path(views_json).parent_path().string();
  // Every view is read and checked before anything renders or is written.
  struct View {
    std::string name;
    Camera camera;
    CueLight light;
  };
  std::vector<View> parsed;
  std::map<std::string, std::string> names;  // name -> where it was first given
  for (const json& view : views["views"]) {
    const std::string where = views_json + ": views[" + std::to_string(parsed.size()) + "]";
    RELIT_REQUIRE(view.is_object(), where, ": expected an object with name, cam_from_world and light");
    const json& name_json = JsonField(view, "name", where);
    RELIT_REQUIRE(name_json.is_string(), where, ".name: expected a string");
    const std::string name = name_json.get<std::string>();
    RELIT_REQUIRE(name.find('/') == std::string::npos && !name.empty() && name != "." && name != ".." &&
                      name != "render" && name[0] != '.',
                  where, ".name: '", name, "' must be a plain file name (no '/', not hidden, not 'render')");
    const auto [it, inserted] = names.emplace(name, where);
    RELIT_REQUIRE(inserted, where, ".name: '", name, "' is also the name of ", it->second,
                  "; give every view its own name (each becomes NAME.exr and NAME.png)");
    const Intrinsics intrinsics =
        view.contains("intrinsics") ? IntrinsicsFromJson(view["intrinsics"], where + ".intrinsics") : asset.camera;
    parsed.push_back({name, Camera(intrinsics, Rigid3FromJson(JsonField(view, "cam_from_world", where), where)),
                      LightFromJson(JsonField(view, "light", where), base, where + ".light")});
  }
  OutputGuard guard{"relit-render", force, {views_json, asset.mesh}};
  for (const std::string& model : asset.partition_models) guard.inputs.push_back(model);
  StageRun out(AtomicDir(out_dir, guard), record, "render.json");
  RelitRenderer renderer(asset, device);
  CueRenderSettings settings;
  settings.samples_per_pixel = options.samples_per_pixel;
  settings.denoise = options.denoise_cues;
  Progress progress("render views", static_cast<int64_t>(parsed.size()));
  auto timer = record.Time("render_views");
  int index = 0;
  for (const View& view : parsed) {
    settings.seed = 9000 + index++;
    WriteRgba((out.path() / view.name).string(), renderer.Render(view.camera, view.light, settings));
    progress.Advance();
  }
  progress.Finish();
  record.Set("views", index);
  out.Commit();
}

int RunRender(int argc, char** argv) {
  CLI::App app{"relit-render: render an exported relit asset (relit-relight export) for any cameras and "
               "lights, without the workspace. See docs/relight.md for the views file."};
  std::string asset_dir, views, out, device, log_level = "info";
  int samples = 16;
  app.add_option("--asset", asset_dir, "asset folder (manifest.json)")->required()->check(CLI::ExistingDirectory);
  app.add_option("--views", views, "JSON file of cameras and lights")->required()->check(CLI::ExistingFile);
  app.add_option("--out", out, "output folder")->required();
  app.add_option("--samples-per-pixel", samples, "cue paths per pixel (default 16)");
  app.add_option("--device", device, "cpu | cuda | auto (default cpu)");
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  bool force = false;
  app.add_flag("--force", force, "replace an --out folder that relit-render did not write");
  CLI11_PARSE(app, argc, argv);
  SetVerbosity(ParseLogLevel(log_level));
  RenderStageOptions options;
  options.samples_per_pixel = samples;
  CheckOptions(options, "render");
  AssetDescription asset = ReadAsset(asset_dir);
  RunRecord record("relit-render");
  record.SetCommandLine(argc, argv);
  record.SetOptions({{"asset", asset_dir}, {"views", views}, {"samples_per_pixel", samples}, {"device", device}});
  RunRenderViews(asset, views, out, options, record, device, force);
  return 0;
}

}  // namespace relit::relight
