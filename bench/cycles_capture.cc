#include "bench/cycles_capture.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <sys/wait.h>

#include "bench/cycles.h"
#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/render/envmaps.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "tools/synth/capture_plan.h"
#include "tools/synth/ffmpeg_io.h"
#include "tools/synth/scene.h"
#include "tools/synth/sensor.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

namespace relit::bench {

namespace fs = std::filesystem;
using nlohmann::json;
using synth::CapturePlan;
using synth::FramePlan;
using synth::SynthOptions;
using synth::SynthScene;
using synth::VideoPlan;

namespace {

constexpr int kSphereObjectId = 2;

std::string Fnv1a64Hex(const std::string& bytes) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ULL;
  char out[17];
  std::snprintf(out, sizeof(out), "%016llx", static_cast<unsigned long long>(h));
  return out;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in.good(), "cannot read ", path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The script's code as a cache key: its docstring and comment lines left
// out, so that editing the documentation does not throw away hours of renders.
std::string ScriptKey(const std::string& script) {
  const size_t open = script.find("\"\"\"");
  const size_t close = open == std::string::npos ? open : script.find("\"\"\"", open + 3);
  std::istringstream lines(close == std::string::npos ? script : script.substr(close + 3));
  std::string key;
  for (std::string line; std::getline(lines, line);) {
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    key += line.substr(0, line.find("  # ")) + "\n";
  }
  return key;
}

json Matrix(const Rigid3& t) {
  const Eigen::Matrix3d r = t.rotation.toRotationMatrix();
  json m = json::array();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m.push_back(r(i, j));
    m.push_back(t.translation(i));
  }
  for (double v : {0.0, 0.0, 0.0, 1.0}) m.push_back(v);
  return m;
}

// The relit-synth bunny scene plus a glossy sphere beside the bunny, on the
// board; the aim point and radius over both foreground objects.
SynthScene BuildCyclesScene(const CyclesCaptureOptions& o) {
  RELIT_REQUIRE(o.synth.preset == "bunny", "the Cycles capture paints the bunny (preset: bunny), got preset '",
                o.synth.preset, "'");
  SynthScene scene = synth::BuildScene("bunny", o.synth.board, synth::DefaultAssetsDir());
  const Eigen::AlignedBox3f bunny = scene.objects.front().mesh.Bounds();
  const float r = static_cast<float>(o.sphere_radius_m);
  const Eigen::Vector3f centre(bunny.max().x() + r + 0.004f, bunny.min().y() + r, r + 0.0005f);
  synth::SynthObject sphere;
  sphere.name = "sphere";
  sphere.object_id = kSphereObjectId;
  sphere.mesh = render::MakeSphere(centre, r, 96, 48);
  sphere.material = render::Material::Glossy(render::Rgb(0.55f, 0.06f, 0.04f), render::Rgb::Constant(0.5f), 0.12f);
  scene.objects.insert(scene.objects.begin() + 1, std::move(sphere));
  Eigen::AlignedBox3f bounds;
  for (const auto& object : scene.objects) {
    if (object.foreground) bounds.extend(object.mesh.Bounds());
  }
  scene.target_world = bounds.center().cast<double>();
  scene.target_world.z() *= 0.5;  // as BuildScene: aim at half the height
  scene.foreground_radius_m = 0.5 * bounds.sizes().norm();
  return scene;
}

// A pinhole canvas that Cycles renders and the map from every pixel of the
// distorted phone frame into it (bilinear resampling applies the lens).
struct Canvas {
  Intrinsics pinhole;
  std::vector<Eigen::Vector2f> source;  // canvas pixel (OpenCV centre convention) per output pixel
};

Canvas MakeCanvas(const Intrinsics& lens) {
  Canvas canvas;
  canvas.source.resize(static_cast<size_t>(lens.width) * lens.height);
  Eigen::AlignedBox2d box;
  for (int y = 0; y < lens.height; ++y) {
    for (int x = 0; x < lens.width; ++x) {
      const Eigen::Vector2d n =
          Undistort(lens.distortion, Eigen::Vector2d((x - lens.cx) / lens.fx, (y - lens.cy) / lens.fy));
      const Eigen::Vector2d p(lens.fx * n.x() + lens.cx, lens.fy * n.y() + lens.cy);
      canvas.source[static_cast<size_t>(y) * lens.width + x] = p.cast<float>();
      box.extend(p);
    }
  }
  const int ox = 2 - static_cast<int>(std::floor(box.min().x()));
  const int oy = 2 - static_cast<int>(std::floor(box.min().y()));
  canvas.pinhole = lens.WithoutDistortion();
  canvas.pinhole.width = static_cast<int>(std::ceil(box.max().x())) + ox + 3;
  canvas.pinhole.height = static_cast<int>(std::ceil(box.max().y())) + oy + 3;
  canvas.pinhole.cx += ox;
  canvas.pinhole.cy += oy;
  for (Eigen::Vector2f& p : canvas.source) p += Eigen::Vector2f(ox, oy);
  return canvas;
}

Image Resample(const Image& canvas, const Canvas& map, int width, int height) {
  RELIT_REQUIRE(canvas.width() == map.pinhole.width && canvas.height() == map.pinhole.height,
                "Cycles canvas is ", canvas.width(), "x", canvas.height(), ", expected ", map.pinhole.width, "x",
                map.pinhole.height, " (stale render cache?)");
  Image out(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2f p = map.source[static_cast<size_t>(y) * width + x];
      const int x0 = static_cast<int>(std::floor(p.x())), y0 = static_cast<int>(std::floor(p.y()));
      const float ax = p.x() - x0, ay = p.y() - y0;
      for (int c = 0; c < 3; ++c) {
        out.at(x, y, c) = (1 - ay) * ((1 - ax) * canvas.at(x0, y0, c) + ax * canvas.at(x0 + 1, y0, c)) +
                          ay * ((1 - ax) * canvas.at(x0, y0 + 1, c) + ax * canvas.at(x0 + 1, y0 + 1, c));
      }
    }
  }
  return out;
}

// relit's equirectangular map in Cycles' layout: Cycles has u = 0.5 -
// atan2(y, x) / 2pi where relit has u = atan2(y, x) / 2pi (rows agree), so
// Cycles column j shows relit column (W/2 - 1 - j) mod W (checked by
// rendering a map with marked columns).
Image ToCyclesEquirect(const Image& relit_map) {
  const int w = relit_map.width();
  Image out(w, relit_map.height(), relit_map.channels());
  for (int y = 0; y < relit_map.height(); ++y) {
    for (int j = 0; j < w; ++j) {
      const int x = ((w / 2 - 1 - j) % w + w) % w;
      for (int c = 0; c < relit_map.channels(); ++c) out.at(j, y, c) = relit_map.at(x, y, c);
    }
  }
  return out;
}

json CameraJob(const Intrinsics& k, const Rigid3& cam_from_world) {
  return {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"cx", k.cx}, {"cy", k.cy},
          {"cam_from_world", Matrix(cam_from_world)}};
}

json PointLightJson(const Eigen::Vector3d& position, const Eigen::Vector3d& rgb) {
  return {{"type", "point"}, {"position_world_m", ToJson(position)}, {"intensity_w_per_sr", ToJson(rgb)}};
}

json EvalLightJson(const synth::EvalLight& light) {
  if (light.type == "point") return PointLightJson(light.position_world, light.rgb);
  if (light.type == "directional") {
    return {{"type", "directional"}, {"direction_to_light_world", ToJson(light.direction_to_light)},
            {"irradiance", ToJson(light.rgb)}};
  }
  return {{"type", "environment"}, {"envmap", light.envmap}, {"scale", light.rgb.x()}};
}

std::string FrameExr(const std::string& video, int index) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s/%06d.exr", video.c_str(), index);
  return name;
}

// Blender's scene description and jobs (outputs relative to the cache folder).
json MakeSpec(const CyclesCaptureOptions& o, const CapturePlan& plan, const fs::path& scene_dir,
              const std::map<std::string, Canvas>& canvases) {
  const SynthOptions& s = o.synth;
  json spec = {{"threads", o.threads}, {"max_bounces", s.max_depth - 1}};
  json materials = CyclesMaterials();
  materials["board"] = {{"kind", "texture"},
                        {"texture", (scene_dir / synth::TexturePath("board_albedo")).string()}};
  for (const char* name : {"bunny", "sphere", "board", "table"}) {
    spec["objects"].push_back({{"name", name},
                               {"mesh", (scene_dir / synth::MeshPath(name)).string()},
                               {"material", materials[name]},
                               {"smooth", std::string(name) == "bunny" || std::string(name) == "sphere"},
                               {"foreground", std::string(name) == "bunny" || std::string(name) == "sphere"}});
  }
  for (const char* name : {"sky", "studio"}) spec["envmaps"][name] = (scene_dir / "envmaps" / (std::string(name) + ".exr")).string();
  json options = OptionsToJson(s);
  options.erase("out");
  spec["synth_options"] = options;
  json jobs = json::array();
  int seed = 1;
  for (const VideoPlan* video : {&plan.view, &plan.light}) {
    for (const FramePlan& f : video->frames) {
      json job = CameraJob(canvases.at(video->name).pinhole, f.cam_from_world);
      job.update({{"output", FrameExr(video->name, f.index)}, {"spp", s.samples_per_pixel}, {"seed", seed++},
                  {"kind", "video"},
                  {"lights", {PointLightJson(f.light_position_world,
                                             Eigen::Vector3d::Constant(s.flash_intensity_w_per_sr))}}});
      jobs.push_back(job);
    }
  }
  for (const synth::EvalView& view : plan.eval_views) {
    for (size_t l = 0; l < plan.eval_lights.size(); ++l) {
      const synth::EvalLight& light = plan.eval_lights[l];
      // As relit-synth: the image is the mean of two independent halves of
      // its samples, the first kept for eval's noise floor.
      const std::string image = synth::EvalImagePath(view.name, light.name);
      const std::string second = image.substr(0, image.size() - 4) + ".second_half.exr";  // averaged in, not kept
      const int halves = s.eval_noise_halves ? 2 : 1;
      for (int half = 0; half < halves; ++half) {
        json job = CameraJob(plan.eval_intrinsics, view.cam_from_world);
        job.update({{"output", halves == 1 ? image : half == 0 ? synth::EvalHalfImagePath(view.name, light.name) : second},
                    {"spp", (s.eval_samples_per_pixel + halves - 1) / halves}, {"seed", seed++},
                    {"kind", half == 0 ? "eval" : "eval_second_half"},
                    {"lights", {EvalLightJson(light)}}});
        if (halves == 2 && half == 0) job.update({{"image", image}, {"second_half", second}});
        jobs.push_back(job);
      }
    }
    json alpha = CameraJob(plan.eval_intrinsics, view.cam_from_world);
    alpha.update({{"output", synth::EvalAlphaPath(view.name)}, {"spp", 64}, {"seed", seed++}, {"kind", "alpha"},
                  {"alpha_only", true}, {"lights", json::array()}});
    jobs.push_back(alpha);
  }
  spec["jobs"] = jobs;
  return spec;
}

// Runs Blender on the jobs whose EXR is missing, with a progress bar weighted
// by samples (video frames and eval images differ ~10x in cost).
void RunBlender(const CyclesCaptureOptions& o, const json& spec, const fs::path& cache,
                CyclesCaptureSummary* summary) {
  double total_weight = 0, done_weight = 0;
  std::vector<double> weights;
  for (const json& job : spec["jobs"]) {
    weights.push_back(job["width"].get<double>() * job["height"].get<double>() * job["spp"].get<double>() * 1e-6);
    if (!fs::exists(cache / job["output"].get<std::string>())) total_weight += weights.back();
  }
  if (total_weight == 0) return;
  const std::string blender = FindExecutable(o.blender);
  RELIT_REQUIRE(!blender.empty(), "blender not found (install it with tools/install-bench-deps)");
  const std::string spec_path = (cache / "spec.json").string();
  const std::string log_path = (cache / "blender.log").string();
  const std::string command = ShellQuote(blender) + " -b --factory-startup -noaudio --python-exit-code 1 --python " +
                              ShellQuote(o.script) + " -- --spec " + ShellQuote(spec_path) + " 2>&1";
  spdlog::info("cycles: rendering {:.0f} Msamples of {} jobs into {}; log {}", total_weight, spec["jobs"].size(),
               cache.string(), log_path);
  const auto start = std::chrono::steady_clock::now();
  FILE* pipe = popen(command.c_str(), "r");
  RELIT_REQUIRE(pipe != nullptr, "cannot start blender");
  std::ofstream log(log_path);
  Progress progress("cycles Msamples", static_cast<int64_t>(std::ceil(total_weight)));
  double video_s = 0, eval_s = 0;
  int video_n = 0, eval_n = 0;
  std::string line;
  char buffer[4096];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) {
    line += buffer;
    if (line.empty() || line.back() != '\n') continue;  // a long line arrives in pieces
    log << line << std::flush;
    int index = 0, total = 0;
    double seconds = 0;
    if (line.rfind("RELIT_JOB ", 0) == 0 &&
        std::sscanf(line.c_str(), "RELIT_JOB %d %d %lf", &index, &total, &seconds) == 3 && seconds >= 0) {
      const std::string kind = spec["jobs"].at(index)["kind"];
      if (kind == "video") video_s += seconds, ++video_n;
      if (kind == "eval") eval_s += seconds, ++eval_n;
      ++summary->jobs_rendered;
      const double before = done_weight;
      done_weight += weights.at(index);
      progress.Advance(static_cast<int64_t>(std::floor(done_weight)) - static_cast<int64_t>(std::floor(before)));
      progress.SetStatus("job " + std::to_string(index + 1) + "/" + std::to_string(total) + " " + kind);
    }
    line.clear();
  }
  const int raw = pclose(pipe);
  const int exit_code = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  log.close();
  progress.Finish();
  summary->render_s = SecondsSince(start);
  if (video_n > 0) summary->video_frame_s = video_s / video_n;
  if (eval_n > 0) summary->eval_image_s = eval_s / eval_n;
  if (exit_code != 0) {
    std::string last_error = "see " + log_path;
    std::ifstream log(log_path);
    for (std::string line; std::getline(log, line);) {
      if (line.find("Error") != std::string::npos) last_error = line + " (" + log_path + ")";
    }
    Fail("blender exited with code ", exit_code, ": ", last_error);
  }
}

}  // namespace

json CyclesMaterials() {
  // Blender Principled BSDF parameters (bench/cycles_capture.py); relit's
  // materials never see them: the eval truth is all relit knows.
  return {{"bunny", {{"kind", "paint"}, {"color_a", {0.70, 0.48, 0.16}}, {"color_b", {0.10, 0.28, 0.55}},
                     {"scale", 60.0}, {"ramp", {0.45, 0.55}}, {"roughness", 0.35}, {"specular", 0.5}}},
          {"sphere", {{"kind", "uniform"}, {"color_a", {0.55, 0.06, 0.04}}, {"roughness", 0.12}, {"specular", 0.5}}},
          {"table", {{"kind", "wood"}, {"color_a", {0.22, 0.14, 0.08}}, {"color_b", {0.12, 0.07, 0.04}},
                     {"scale", 12.0}, {"ramp", {0.3, 0.7}}, {"roughness", 0.45}, {"specular", 0.3}}}};
}

json CyclesCaptureSummary::ToJson() const {
  return {{"capture_dir", capture_dir},     {"spec_hash", spec_hash},         {"capture_reused", capture_reused},
          {"jobs", jobs},                   {"jobs_rendered", jobs_rendered}, {"render_s", render_s},
          {"video_frame_s", video_frame_s}, {"eval_image_s", eval_image_s},   {"assemble_s", assemble_s}};
}

namespace {

// Phone frames through the lens and the sensor, into the MP4 with its audio.
void EncodeVideo(const SynthOptions& s, const VideoPlan& video, int video_index, const Canvas& canvas,
                 const fs::path& cache, const fs::path& root, Progress* progress) {
  synth::VideoEncoder encoder((root / (video.name + ".mp4")).string(),
                              synth::VideoEncodeParamsFor(video, s.crf, root.string()));
  for (const FramePlan& f : video.frames) {
    const Image radiance = Resample(ReadImage((cache / FrameExr(video.name, f.index)).string()), canvas,
                                    video.intrinsics.width, video.intrinsics.height);
    synth::SensorParams sensor;
    sensor.exposure = s.exposure * f.exposure_scale;
    sensor.full_well_e = s.full_well_e;
    sensor.read_noise_e = s.read_noise_e;
    const uint64_t stream = 1000 + static_cast<uint64_t>(video_index) * 1000000 + f.index;
    encoder.AddFrame(synth::SensorCapture(radiance, sensor, synth::SubSeed(s.seed, stream), 1));
    progress->Advance();
  }
  encoder.Finish();
}

void CheckReproducible(const SynthOptions& s, const CapturePlan& plan) {
  RELIT_REQUIRE(s.view_rolling_shutter_s == 0 && s.light_rolling_shutter_s == 0,
                "the Cycles capture renders a global shutter: set view/light_rolling_shutter_s to 0");
  RELIT_REQUIRE(s.view_flash_shadow_factor == 1, "the Cycles capture traces the flash's shadows: "
                "view_flash_shadow_factor must be 1 (the mask is relit-synth's stand-in)");
  RELIT_REQUIRE(plan.geometry.frames.empty() && plan.view_board_clip.frames.empty(),
                "the Cycles capture has no geometry pass or board clips");
  RELIT_REQUIRE(plan.view.intrinsics.fx == plan.view.intrinsics.fy && plan.light.intrinsics.fx == plan.light.intrinsics.fy,
                "the Cycles capture needs square pixels (fx == fy)");
}

}  // namespace

CyclesCaptureSummary MakeCyclesCapture(const CyclesCaptureOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  RELIT_REQUIRE(!options.out_dir.empty(), "--out is required");
  const fs::path out = fs::absolute(options.out_dir);
  CyclesCaptureOptions o = options;
  o.synth.out = (out / "capture").string();  // where the capture goes (not part of the cache key)
  CheckOptions(o.synth);
  const fs::path scene_dir = out / "render" / "scene";
  const SynthScene scene = BuildCyclesScene(o);
  const CapturePlan plan = synth::MakeCapturePlan(o.synth, scene);
  CheckReproducible(o.synth, plan);

  // What Blender reads: the truth meshes (world frame), the board texture, the maps.
  synth::WriteSceneTruth(scene, scene_dir.string());
  fs::create_directories(scene_dir / "envmaps");
  const std::map<std::string, Image> envmaps = {
      {"sky", render::MakeSkyMap(o.synth.envmap_width_px, plan.sun_elevation_rad, plan.sun_azimuth_rad)},
      {"studio", render::MakeStudioMap(o.synth.envmap_width_px)}};
  for (const auto& [name, map] : envmaps) {
    WriteImage((scene_dir / "envmaps" / (name + ".exr")).string(), ToCyclesEquirect(map), PixelStorage::kFloat);
  }
  const std::map<std::string, Canvas> canvases = {{"view", MakeCanvas(plan.view.intrinsics)},
                                                  {"light", MakeCanvas(plan.light.intrinsics)}};
  json spec = MakeSpec(o, plan, scene_dir, canvases);
  // Two caches, so that changing the eval set keeps the video frames and the
  // other way round: each keyed by its jobs, the scene files' contents, the
  // scene description and the script.
  std::string scene_key = ScriptKey(ReadText(o.script));
  for (const json& object : spec["objects"]) {
    scene_key += object.dump() + ReadText(object["mesh"]);
    if (object["material"].contains("texture")) scene_key += ReadText(object["material"]["texture"]);
  }
  for (const auto& [name, path] : spec["envmaps"].items()) scene_key += name + ReadText(path);
  scene_key += json{{"max_bounces", spec["max_bounces"]}}.dump();
  std::string video_jobs, eval_jobs;
  for (const json& job : spec["jobs"]) (job["kind"] == "video" ? video_jobs : eval_jobs) += job.dump();
  const std::string video_dir = "videos-" + Fnv1a64Hex(scene_key + video_jobs);
  const std::string eval_dir = "eval-" + Fnv1a64Hex(scene_key + eval_jobs);
  for (json& job : spec["jobs"]) {
    job["output"] = (job["kind"] == "video" ? video_dir : eval_dir) + "/" + job["output"].get<std::string>();
  }
  json capture_options = OptionsToJson(o.synth);
  capture_options.erase("out");
  CyclesCaptureSummary summary;
  summary.spec_hash = Fnv1a64Hex(video_dir + eval_dir + capture_options.dump());
  summary.jobs = static_cast<int>(spec["jobs"].size());
  const fs::path cache = out / "render";
  summary.capture_dir = (out / "capture").string();

  const fs::path truth_path = out / "capture" / "truth.json";
  if (fs::exists(truth_path)) {
    const json truth = ReadJsonFile(truth_path.string(), synth::kTruthKind, synth::kTruthVersion);
    if (truth.value("render", json::object()).value("spec_hash", "") == summary.spec_hash) {
      summary.capture_reused = true;
      spdlog::info("cycles: {} is up to date (spec {})", summary.capture_dir, summary.spec_hash);
      return summary;
    }
  }
  fs::create_directories(cache);
  spec["output_root"] = cache.string();
  WriteJsonFile((cache / "spec.json").string(), "cycles_capture_spec", 1, spec);
  RunBlender(o, spec, cache, &summary);
  for (const json& job : spec["jobs"]) {
    RELIT_REQUIRE(fs::exists(cache / job["output"].get<std::string>()), "Cycles did not write ",
                  (cache / job["output"].get<std::string>()).string());
  }

  const auto assemble = std::chrono::steady_clock::now();
  AtomicDir folder(out / "capture");
  const fs::path root = folder.path();
  synth::WriteSceneTruth(scene, root.string());
  synth::WriteCaptureAudio(o.synth, plan, root.string());
  Progress progress("assemble", static_cast<int64_t>(plan.view.frames.size() + plan.light.frames.size()));
  EncodeVideo(o.synth, plan.view, 0, canvases.at("view"), cache / video_dir, root, &progress);
  EncodeVideo(o.synth, plan.light, 1, canvases.at("light"), cache / video_dir, root, &progress);
  progress.Finish();
  for (const auto& [name, map] : envmaps) {
    fs::create_directories(root / "eval/envmaps");
    WriteImage((root / synth::EnvmapPath(name)).string(), map, PixelStorage::kFloat);
  }
  for (const json& job : spec["jobs"]) {
    if (job["kind"] == "video" || job["kind"] == "eval_second_half") continue;
    const std::string cached = job["output"];
    const std::string rel = cached.substr(eval_dir.size() + 1);  // its path in the capture
    const Image rendered = ReadImage((cache / cached).string());
    fs::create_directories((root / rel).parent_path());
    if (job.contains("second_half")) {  // a first half: kept, and the image is the mean of both
      const Image first = rendered.SelectChannels(std::vector<int>{0, 1, 2});
      Image mean = ReadImage((cache / eval_dir / job["second_half"].get<std::string>()).string())
                       .SelectChannels(std::vector<int>{0, 1, 2});
      RELIT_REQUIRE(mean.data().size() == first.data().size(), "Cycles' eval halves of ", rel, " differ in size");
      for (size_t i = 0; i < mean.data().size(); ++i) mean.data()[i] = 0.5f * (mean.data()[i] + first.data()[i]);
      WriteImage((root / rel).string(), first, PixelStorage::kHalf);
      WriteImage((root / job["image"].get<std::string>()).string(), mean, PixelStorage::kHalf);
    } else if (job["kind"] == "alpha") {
      Image alpha = rendered.SelectChannels(std::vector<int>{3});
      alpha.set_channel_names({"A"});
      WriteImage((root / rel).string(), alpha, PixelStorage::kHalf);
    } else {
      WriteImage((root / rel).string(), rendered.SelectChannels(std::vector<int>{0, 1, 2}), PixelStorage::kHalf);
    }
  }

  json truth = synth::MakeTruthJson(o.synth, scene, plan, synth::RenderedParts{true, true});
  truth["generator"] = "relit-bench-cycles-capture";
  truth["render"] = {{"renderer", "Blender Cycles (CPU), bench/cycles_capture.py"},
                     {"spec_hash", summary.spec_hash},
                     {"samples_per_pixel", o.synth.samples_per_pixel},
                     {"eval_samples_per_pixel", o.synth.eval_samples_per_pixel},
                     {"max_bounces", o.synth.max_depth - 1},
                     {"lens", "pinhole canvas rendered by Cycles, distorted by bilinear resampling"}};
  const json materials = CyclesMaterials();
  for (json& object : truth["objects"]) object["material"] = materials.at(object["name"].get<std::string>());
  for (json& object : truth["background"]) {
    if (object["name"] == "table") object["material"] = materials.at("table");
  }
  for (json& frame : truth["videos"]["view"]["frames"]) frame.erase("alpha");  // no per-frame mattes
  WriteJsonFile((root / "truth.json").string(), synth::kTruthKind, synth::kTruthVersion, truth);
  RunRecord record("relit-bench-cycles-capture");
  json recorded = OptionsToJson(o.synth);
  recorded["blender_threads"] = o.threads;
  record.SetOptions(recorded);
  record.Set("cycles", summary.ToJson());
  summary.assemble_s = SecondsSince(assemble);
  record.AddTiming("cycles_render", summary.render_s);
  record.AddTiming("assemble", summary.assemble_s);
  record.Set("capture_s", SecondsSince(start));
  record.Write((root / "run.json").string());
  folder.Commit();
  return summary;
}

}  // namespace relit::bench
