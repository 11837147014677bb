#include "tools/synth/synth.h"

#include <array>
#include <chrono>
#include <filesystem>

#include <CLI/CLI.hpp>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/render/path_tracer.h"
#include "core/run_record.h"
#include "tools/synth/audio.h"
#include "tools/synth/capture_plan.h"
#include "core/render/envmaps.h"
#include "tools/synth/ffmpeg_io.h"
#include "tools/synth/scene.h"
#include "tools/synth/sensor.h"
#include "tools/synth/truth.h"

namespace relit::synth {

namespace {

namespace fs = std::filesystem;

enum RenderStream : uint64_t { kRoomSound = 20, kGeometryRoom, kMic, kRender = 1000 };

render::Vec3f F(const Eigen::Vector3d& v) { return v.cast<float>(); }

Image AlphaChannel(const render::RenderResult& result) {
  Image alpha = result.alpha.SelectChannels(std::vector<int>{0});
  alpha.set_channel_names({"A"});
  return alpha;
}

// The camera of the pixel rectangle at (x0, y0), `width` x `height`, of `k`:
// same rays, pixel (x, y) of the crop is (x0 + x, y0 + y) of the image.
Intrinsics CropIntrinsics(const Intrinsics& k, int x0, int y0, int width, int height) {
  Intrinsics crop = k;
  crop.width = width;
  crop.height = height;
  crop.cx -= x0;
  crop.cy -= y0;
  return crop;
}

// Copies `part`'s radiance and alpha into `into` at (x0, y0).
void PasteAt(const render::RenderResult& part, int x0, int y0, render::RenderResult* into) {
  for (int y = 0; y < part.radiance.height(); ++y) {
    for (int x = 0; x < part.radiance.width(); ++x) {
      for (int c = 0; c < 3; ++c) into->radiance.at(x0 + x, y0 + y, c) = part.radiance.at(x, y, c);
      into->alpha.at(x0 + x, y0 + y, 0) = part.alpha.at(x, y, 0);
    }
  }
}

SensorParams Sensor(const SynthOptions& o) {
  SensorParams sensor;
  sensor.exposure = o.exposure;
  sensor.full_well_e = o.full_well_e;
  sensor.read_noise_e = o.read_noise_e;
  return sensor;
}

render::RenderOptions FrameRenderOptions(int spp, int max_depth, uint64_t seed,
                                         const std::vector<int>& alpha_ids) {
  render::RenderOptions options;
  options.samples_per_pixel = spp;
  options.max_depth = max_depth;
  options.seed = seed;
  options.alpha_object_ids = alpha_ids;
  options.environment_visible = true;
  return options;
}

// The optional flash shadow of phone V's frames (SynthOptions
// view_flash_shadow_*): board and table pixels beyond a line through the
// board, facing away from the flash, darkened. The pixel-centre ray decides.
void ApplyFlashShadow(const SynthOptions& o, const Eigen::Vector3d& flash_world, render::RenderResult* result) {
  Eigen::Vector2d away = -flash_world.head<2>();  // board centre (world origin) minus flash, horizontal
  if (away.norm() < 1e-6) return;
  away.normalize();
  const float factor = static_cast<float>(o.view_flash_shadow_factor);
  for (int y = 0; y < result->radiance.height(); ++y) {
    for (int x = 0; x < result->radiance.width(); ++x) {
      const int id = static_cast<int>(std::lround(result->object_id.at(x, y, 0)));
      if (id != kBoardObjectId && id != kTableObjectId) continue;
      const Eigen::Vector2d p(result->position.at(x, y, 0), result->position.at(x, y, 1));
      if (p.dot(away) <= o.view_flash_shadow_edge_m) continue;
      for (int c = 0; c < 3; ++c) result->radiance.at(x, y, c) *= factor;
    }
  }
}

// One frame's radiance and alpha: in one piece, or band by band for a
// rolling shutter (each band a crop of the lens: same pixels, its own pose
// and flash position).
render::RenderResult RenderFrame(const SynthOptions& o, const VideoPlan& video, const FramePlan& frame,
                                 uint64_t seed, const std::vector<int>& alpha_ids, render::Scene* scene) {
  const auto set_flash = [&](const Eigen::Vector3d& position) {
    if (video.lighting != "flash") return;
    scene->ClearLights();
    render::PointLight flash;
    flash.position = F(position);
    flash.intensity = render::Rgb::Constant(static_cast<float>(o.flash_intensity_w_per_sr));
    scene->AddLight(flash);
  };
  const render::RenderOptions options = FrameRenderOptions(o.samples_per_pixel, o.max_depth, seed, alpha_ids);
  const bool shadow = video.name == "view" && o.view_flash_shadow_factor < 1;
  if (frame.bands.empty()) {
    set_flash(frame.light_position_world);
    render::RenderResult result = render::RenderImage(*scene, Camera(video.intrinsics, frame.cam_from_world), options);
    if (shadow) ApplyFlashShadow(o, frame.light_position_world, &result);
    return result;
  }
  const int width = video.intrinsics.width, height = video.intrinsics.height;
  render::RenderResult full;
  full.radiance = Image(width, height, 3);
  full.alpha = Image(width, height, 1);
  for (size_t b = 0; b < frame.bands.size(); ++b) {
    const RowBand& band = frame.bands[b];
    const Intrinsics crop = CropIntrinsics(video.intrinsics, 0, band.row_begin, width, band.row_end - band.row_begin);
    set_flash(band.light_position_world);
    render::RenderOptions band_options = options;
    band_options.seed = render::MixBits(seed + 0x9e37 * (b + 1));
    render::RenderResult part = render::RenderImage(*scene, Camera(crop, band.cam_from_world), band_options);
    if (shadow) ApplyFlashShadow(o, band.light_position_world, &part);
    PasteAt(part, 0, band.row_begin, &full);
  }
  return full;
}

}  // namespace

VideoEncodeParams VideoEncodeParamsFor(const VideoPlan& video, int crf, const std::string& out_dir) {
  VideoEncodeParams encode;
  encode.width_px = video.intrinsics.width;
  encode.height_px = video.intrinsics.height;
  encode.fps = video.fps;
  encode.audio_rate_hz = video.audio_rate_hz;
  encode.audio_start_s = video.audio_start_s;
  encode.crf = crf;
  encode.display_rotation_deg = video.display_rotation_deg;
  encode.audio_wav = (fs::path(out_dir) / "truth" / "audio" / (video.name + ".wav")).string();
  return encode;
}

namespace {

void RenderVideo(const SynthOptions& o, const VideoPlan& video, int video_index,
                 const SynthScene& synth_scene, render::Scene* scene,
                 const render::EnvironmentLight& environment, const fs::path& root, bool write_alpha,
                 Progress* progress) {
  VideoEncoder encoder((root / (video.name + ".mp4")).string(), VideoEncodeParamsFor(video, o.crf, root.string()));
  const std::vector<int> alpha_ids = synth_scene.ForegroundIds();
  if (video.lighting != "flash") {
    scene->ClearLights();
    scene->SetEnvironment(environment);
  }
  for (const FramePlan& frame : video.frames) {
    const uint64_t stream = kRender + static_cast<uint64_t>(video_index) * 1000000 + frame.index;
    const render::RenderResult result = RenderFrame(o, video, frame, SubSeed(o.seed, stream), alpha_ids, scene);
    SensorParams sensor = Sensor(o);
    sensor.exposure *= frame.exposure_scale;
    encoder.AddFrame(SensorCapture(result.radiance, sensor, SubSeed(o.seed, stream), 1));
    if (write_alpha) {
      WriteImage((root / AlphaPath(video.name, frame.index)).string(), AlphaChannel(result),
                 PixelStorage::kHalf);
    }
    progress->Advance();
  }
  encoder.Finish();
}

// Board-only frames as PNG files (what a user exports from a board video):
// the object removed, lit by the room so no flash shadows the print.
void RenderBoardClip(const SynthOptions& o, const VideoPlan& clip, int clip_index,
                     const SynthScene& synth_scene, const render::EnvironmentLight& room,
                     const fs::path& root, Progress* progress) {
  render::Scene scene;
  for (const SynthObject& object : synth_scene.objects) {
    if (object.object_id == kBoardObjectId || object.object_id == kTableObjectId) {
      scene.AddObject(object.mesh, object.material, object.object_id);
    }
  }
  scene.Commit();
  scene.SetEnvironment(room);
  const SensorParams sensor = Sensor(o);
  const fs::path folder = root / BoardClipFolder(clip.phone);
  fs::create_directories(folder);
  for (const FramePlan& frame : clip.frames) {
    const uint64_t stream = kRender + 8000000 + static_cast<uint64_t>(clip_index) * 10000 + frame.index;
    const render::RenderResult result =
        render::RenderImage(scene, Camera(clip.intrinsics, frame.cam_from_world),
                            FrameRenderOptions(o.samples_per_pixel, o.max_depth, SubSeed(o.seed, stream), {}));
    const std::vector<uint8_t> rgb = SensorCapture(result.radiance, sensor, SubSeed(o.seed, stream), 1);
    const int width = clip.intrinsics.width, height = clip.intrinsics.height;
    Image png(width, height, 3);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        for (int c = 0; c < 3; ++c) png.at(x, y, c) = rgb[(static_cast<size_t>(y) * width + x) * 3 + c] / 255.0f;
      }
    }
    WriteImage((root / BoardClipFramePath(clip.phone, frame.index)).string(),
               RotatedForDisplay(png, clip.display_rotation_deg), PixelStorage::kUint8);
    progress->Advance();
  }
}

// The pixel box (x0, y0, x1, y1 exclusive) where the foreground's bounding
// sphere can project, a few pixels wider; the whole image when the sphere
// reaches behind the camera.
std::array<int, 4> ForegroundBox(const Camera& camera, const SynthScene& synth_scene) {
  const Intrinsics& k = camera.intrinsics();
  const std::array<int, 4> whole = {0, 0, k.width, k.height};
  const double r = synth_scene.foreground_radius_m;
  double x0 = k.width, y0 = k.height, x1 = 0, y1 = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d offset((corner & 1 ? r : -r), (corner & 2 ? r : -r), (corner & 4 ? r : -r));
    const Eigen::Vector3d p = camera.cam_from_world() * (synth_scene.target_world + offset);
    if (p.z() <= 1e-6) return whole;
    const Eigen::Vector2d px = camera.ProjectCameraPoint(p);
    x0 = std::min(x0, px.x()), y0 = std::min(y0, px.y()), x1 = std::max(x1, px.x()), y1 = std::max(y1, px.y());
  }
  constexpr int kMarginPx = 4;
  return {std::clamp(static_cast<int>(std::floor(x0)) - kMarginPx, 0, k.width),
          std::clamp(static_cast<int>(std::floor(y0)) - kMarginPx, 0, k.height),
          std::clamp(static_cast<int>(std::ceil(x1)) + kMarginPx + 1, 0, k.width),
          std::clamp(static_cast<int>(std::ceil(y1)) + kMarginPx + 1, 0, k.height)};
}

// An eval image: `box` at `spp`, the rest from `background` (rendered at
// fewer samples; null: the box is the whole image).
render::RenderResult RenderEvalImage(const render::Scene& scene, const Camera& camera, const std::array<int, 4>& box,
                                     const render::RenderOptions& options, const render::RenderResult* background) {
  if (background == nullptr) return render::RenderImage(scene, camera, options);
  render::RenderResult out = *background;
  if (box[2] <= box[0] || box[3] <= box[1]) return out;  // the foreground is outside the frame
  const Intrinsics crop = CropIntrinsics(camera.intrinsics(), box[0], box[1], box[2] - box[0], box[3] - box[1]);
  PasteAt(render::RenderImage(scene, Camera(crop, camera.cam_from_world()), options), box[0], box[1], &out);
  return out;
}

// `into` becomes the mean of itself and `other` (radiance and alpha).
void AverageInto(const render::RenderResult& other, render::RenderResult* into) {
  const auto average = [](const Image& second, Image* image) {
    RELIT_REQUIRE(second.data().size() == image->data().size(), "eval halves differ in size");
    for (size_t i = 0; i < image->data().size(); ++i) image->data()[i] = 0.5f * (image->data()[i] + second.data()[i]);
  };
  average(other.radiance, &into->radiance);
  average(other.alpha, &into->alpha);
}

int RenderEvalSet(const SynthOptions& o, const CapturePlan& plan, const SynthScene& synth_scene,
                  render::Scene* scene, const fs::path& root, Progress* progress) {
  const Image sky = render::MakeSkyMap(o.envmap_width_px, plan.sun_elevation_rad, plan.sun_azimuth_rad);
  const Image studio = render::MakeStudioMap(o.envmap_width_px);
  fs::create_directories(root / "eval/envmaps");
  WriteImage((root / EnvmapPath("sky")).string(), sky, PixelStorage::kFloat);
  WriteImage((root / EnvmapPath("studio")).string(), studio, PixelStorage::kFloat);
  const render::EnvironmentLight sky_light(sky), studio_light(studio);
  const std::vector<int> alpha_ids = synth_scene.ForegroundIds();
  int images = 0;
  for (size_t v = 0; v < plan.eval_views.size(); ++v) {
    const EvalView& view = plan.eval_views[v];
    fs::create_directories(root / "eval" / view.name);
    const Camera camera(plan.eval_intrinsics, view.cam_from_world);
    // Eval scores the foreground only (relight/eval.h): its box takes the
    // eval samples, the rest of the frame the background's (a 4-6x saving
    // on the `full` frames, where the object covers a fifth of the image).
    const std::array<int, 4> box = ForegroundBox(camera, synth_scene);
    const bool whole = box == std::array<int, 4>{0, 0, camera.intrinsics().width, camera.intrinsics().height};
    for (size_t l = 0; l < plan.eval_lights.size(); ++l) {
      const EvalLight& light = plan.eval_lights[l];
      const int light_spp = o.EvalSamplesPerPixel(light.type);
      const bool split = !whole && o.eval_background_samples_per_pixel < light_spp;
      scene->ClearLights();
      if (light.type == "point") {
        scene->AddLight(render::PointLight{F(light.position_world), F(light.rgb).array()});
      } else if (light.type == "directional") {
        scene->AddLight(render::DirectionalLight{F(light.direction_to_light), F(light.rgb).array()});
      } else {
        scene->SetEnvironment(light.envmap == "sky" ? sky_light : studio_light);
      }
      const uint64_t stream = kRender + 9000000 + v * 1000 + l;
      render::RenderResult background;
      if (split) {
        background = render::RenderImage(*scene, camera,
                                         FrameRenderOptions(o.eval_background_samples_per_pixel, o.max_depth,
                                                            SubSeed(o.seed, stream + 700000), alpha_ids));
      }
      // With noise halves: the mean of two independent renders at half the
      // samples each, the first kept for eval's noise floor (the pair costs
      // what one render at the full count does).
      const int spp = o.eval_noise_halves ? (light_spp + 1) / 2 : light_spp;
      render::RenderResult result = RenderEvalImage(
          *scene, camera, box, FrameRenderOptions(spp, o.max_depth, SubSeed(o.seed, stream), alpha_ids),
          split ? &background : nullptr);
      if (o.eval_noise_halves) {
        WriteImage((root / EvalHalfImagePath(view.name, light.name)).string(), result.radiance, PixelStorage::kHalf);
        const render::RenderResult second = RenderEvalImage(
            *scene, camera, box,
            FrameRenderOptions(spp, o.max_depth, SubSeed(o.seed, stream + 500000), alpha_ids),
            split ? &background : nullptr);
        AverageInto(second, &result);
      }
      WriteImage((root / EvalImagePath(view.name, light.name)).string(), result.radiance,
                 PixelStorage::kHalf);
      if (l == 0) {
        WriteImage((root / EvalAlphaPath(view.name)).string(), AlphaChannel(result),
                   PixelStorage::kHalf);
      }
      ++images;
      progress->Advance();
    }
  }
  return images;
}

}  // namespace

// Records the room sound of every video into WAV files under truth/audio.
// Each phone records as long as its video, at its own sample rate, from its
// audio_start_s on its own clock.
void WriteCaptureAudio(const SynthOptions& o, const CapturePlan& plan, const std::string& out_dir) {
  const fs::path root(out_dir);
  const RoomSoundParams params;
  const double duration = o.duration_s();
  const auto samples = [](const VideoPlan& video) {
    return static_cast<int64_t>(std::llround(video.duration_s() * video.audio_rate_hz));
  };
  const auto begin_s = [](const VideoPlan& video) { return video.start_common_s + video.audio_start_s; };
  const double begin = std::min(begin_s(plan.view), begin_s(plan.light)) - 0.01;
  const double end = std::max(begin_s(plan.view) + plan.view.duration_s(),
                              begin_s(plan.light) + plan.light.duration_s()) + 0.01;
  const RoomSound room(params, begin, end, plan.clap_times_common_s, SubSeed(o.seed, kRoomSound));
  fs::create_directories(root / "truth/audio");
  WriteWav((root / "truth/audio/view.wav").string(),
           room.Record(begin_s(plan.view), samples(plan.view), plan.view.audio_rate_hz, 1.0,
                       SubSeed(o.seed, kMic)),
           plan.view.audio_rate_hz);
  WriteWav((root / "truth/audio/light.wav").string(),
           room.Record(begin_s(plan.light), samples(plan.light), plan.light.audio_rate_hz,
                       0.8, SubSeed(o.seed, kMic + 1)),
           plan.light.audio_rate_hz);
  if (!plan.geometry.frames.empty()) {
    // A separate session: its own room sound and claps.
    const double geometry_begin = std::min(0.0, plan.geometry.audio_start_s) - 0.01;
    const RoomSound other(params, geometry_begin, duration + plan.geometry.audio_start_s + 0.02,
                          PickClapTimes(0.1 * duration, 0.9 * duration, o.clap_count, 0.05,
                                        SubSeed(o.seed, kGeometryRoom)),
                          SubSeed(o.seed, kGeometryRoom));
    WriteWav((root / "truth/audio/geometry.wav").string(),
             other.Record(plan.geometry.audio_start_s, samples(plan.geometry), plan.geometry.audio_rate_hz,
                          1.0, SubSeed(o.seed, kMic + 2)),
             plan.geometry.audio_rate_hz);
  }
}

Image RotatedForDisplay(const Image& image, int rotation_deg) {
  if (rotation_deg == 0) return image;
  const int w = image.width(), h = image.height();
  const bool swap = rotation_deg == 90 || rotation_deg == 270;
  Image out(swap ? h : w, swap ? w : h, image.channels());
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      int sx = x, sy = y;  // source pixel of displayed pixel (x, y)
      if (rotation_deg == 90) { sx = y; sy = h - 1 - x; }
      if (rotation_deg == 180) { sx = w - 1 - x; sy = h - 1 - y; }
      if (rotation_deg == 270) { sx = w - 1 - y; sy = x; }
      for (int c = 0; c < image.channels(); ++c) out.at(x, y, c) = image.at(sx, sy, c);
    }
  }
  return out;
}

SynthSummary RunSynthImpl(const SynthOptions& options) {
  CheckOptions(options);
  const auto start = std::chrono::steady_clock::now();
  RunRecord record("relit-synth");
  record.SetOptions(OptionsToJson(options));
  AtomicDir out(options.out);
  const fs::path root = out.path();

  SynthScene synth_scene;
  CapturePlan plan;
  {
    auto timer = record.Time("plan");
    const std::string assets = options.assets_dir.empty() ? DefaultAssetsDir() : options.assets_dir;
    synth_scene = BuildScene(options.preset, options.board, assets,
                             CustomMesh{options.mesh_path, options.mesh_height_m, options.mesh_y_up});
    plan = MakeCapturePlan(options, synth_scene);
    WriteSceneTruth(synth_scene, root.string());
    WriteCaptureAudio(options, plan, root.string());
  }
  spdlog::info("relit-synth: preset {} size {} seed {}: {}x{} px, {} frames per video, "
               "light_start_offset_s {:+.6f}",
               options.preset, options.size, options.seed, options.width_px, options.height_px,
               options.frames_per_video, plan.light_start_offset_s);

  SynthSummary summary;
  summary.light_start_offset_s = plan.light_start_offset_s;
  // eval_only renders the same eval set as a full run: every image has its own
  // seed stream, so skipping the videos changes no pixel.
  const RenderedParts parts{!options.truth_only && !options.eval_only, !options.truth_only};
  if (parts.eval) {
    render::Scene scene;
    synth_scene.AddTo(&scene);
    scene.Commit();
    std::vector<const VideoPlan*> videos;
    if (parts.videos) videos = {&plan.view, &plan.light};
    render::EnvironmentLight room;
    const bool clips = parts.videos && !plan.view_board_clip.frames.empty();
    if (parts.videos && (!plan.geometry.frames.empty() || clips)) {
      const Image room_map = render::MakeSoftRoomMap(256);
      WriteImage((root / kGeometryEnvmapPath).string(), room_map, PixelStorage::kFloat);
      room = render::EnvironmentLight(room_map, static_cast<float>(options.geometry_ambient_scale));
    }
    if (parts.videos && !plan.geometry.frames.empty()) videos.push_back(&plan.geometry);
    int total = static_cast<int>(plan.eval_views.size() * plan.eval_lights.size());
    for (const VideoPlan* video : videos) total += static_cast<int>(video->frames.size());
    if (clips) total += static_cast<int>(plan.view_board_clip.frames.size() + plan.light_board_clip.frames.size());
    Progress progress("render", total);
    for (size_t i = 0; i < videos.size(); ++i) {
      auto timer = record.Time("render_" + videos[i]->name);
      RenderVideo(options, *videos[i], static_cast<int>(i), synth_scene, &scene, room, root,
                  videos[i]->phone == "view", &progress);
      summary.frames_rendered += static_cast<int>(videos[i]->frames.size());
    }
    if (clips) {
      auto timer = record.Time("render_board_clips");
      RenderBoardClip(options, plan.view_board_clip, 0, synth_scene, room, root, &progress);
      RenderBoardClip(options, plan.light_board_clip, 1, synth_scene, room, root, &progress);
    }
    {
      auto timer = record.Time("render_eval");
      summary.eval_images = RenderEvalSet(options, plan, synth_scene, &scene, root, &progress);
    }
    progress.Finish();
  }
  WriteJsonFile((root / "truth.json").string(), kTruthKind, kTruthVersion,
                MakeTruthJson(options, synth_scene, plan, parts));
  record.Set("light_start_offset_s", plan.light_start_offset_s);
  record.Set("frames_rendered", summary.frames_rendered);
  record.Set("eval_images", summary.eval_images);
  record.Write((root / "run.json").string());
  out.Commit();
  summary.out_dir = options.out;
  summary.seconds = SecondsSince(start);
  spdlog::info("relit-synth: wrote {} ({} video frames, {} eval images) in {:.1f} s", options.out,
               summary.frames_rendered, summary.eval_images, summary.seconds);
  return summary;
}

int RunSynth(int argc, char** argv) {
  CLI::App app{"relit-synth: render a synthetic dual-phone capture (phone V films, phone L's "
               "flash lights) with complete ground truth. See docs/synthetic.md."};
  std::string config, preset, size, out, mesh, log_level = "info";
  uint64_t seed = 0;
  bool geometry_pass = false, truth_only = false, eval_only = false;
  int eval_views = -1, board_clip = -1;
  app.add_option("--config", config, "YAML file with SynthOptions (unknown keys are errors)")
      ->check(CLI::ExistingFile);
  app.add_option("--preset", preset, "scene: spot | bunny | spheres | mesh (default spot)");
  app.add_option("--mesh", mesh, "OBJ/PLY file for --preset mesh (Y-up, scaled to 12 cm)");
  app.add_option("--size", size, "tiny (tests) | demo (<= 5 min) | full (benchmark) (default tiny)");
  auto* seed_option = app.add_option("--seed", seed, "random seed (default 1)");
  app.add_option("--out", out, "output directory (replaced atomically)");
  app.add_flag("--geometry-pass", geometry_pass, "also render geometry.mp4 under soft ambient light");
  app.add_flag("--truth-only", truth_only, "write truth.json and meshes only, render nothing");
  app.add_flag("--eval-only", eval_only,
               "render only the evaluation set (eval/) and truth.json, no videos; same plan and "
               "pixels as a full run with the same options");
  app.add_option("--eval-views", eval_views,
                 "number of held-out eval views (changes the eval lights too: they are drawn after "
                 "the views; the videos are unchanged)")
      ->check(CLI::Range(0, 1000));
  app.add_option("--board-clip", board_clip,
                 "also render N board-only frames per phone for lens calibration into "
                 "board_clip/view and board_clip/light (calib's intrinsics.*_board_images)")
      ->check(CLI::Range(0, 1000));
  app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
  CLI11_PARSE(app, argc, argv);
  SetVerbosity(ParseLogLevel(log_level));

  // Size defaults first (the size may come from the file), then the file, then flags.
  SynthOptions options = SynthOptions::FromFile(config, size, "tiny");
  if (!preset.empty()) options.preset = preset;
  if (!mesh.empty()) options.mesh_path = mesh;
  if (seed_option->count() > 0) options.seed = seed;
  if (!out.empty()) options.out = out;
  if (geometry_pass) options.geometry_pass = true;
  if (truth_only) options.truth_only = true;
  if (eval_only) options.eval_only = true;
  if (eval_views >= 0) options.eval_views = eval_views;
  if (board_clip >= 0) options.board_clip_frames = board_clip;
  CheckOptions(options);
  RunSynthImpl(options);
  return 0;
}

}  // namespace relit::synth
