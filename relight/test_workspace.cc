#include "relight/test_workspace.h"

#include <cstdio>
#include <filesystem>
#include <map>
#include <tuple>

#include "core/image.h"
#include "core/json_file.h"
#include "core/render/envmaps.h"
#include "core/render/path_tracer.h"
#include "core/workspace.h"
#include "tools/synth/capture_plan.h"
#include "tools/synth/scene.h"
#include "tools/synth/synth_options.h"
#include "tools/synth/truth.h"

namespace relit::relight::testing {

namespace fs = std::filesystem;

namespace {

// Moves every vertex along the mean normal of all faces around its position
// (UV seams split vertices; keying by position keeps the surface closed).
void Inflate(render::TriangleMesh& mesh, double offset_m) {
  auto key = [](const Eigen::Vector3f& p) {
    return std::make_tuple(std::lround(p.x() * 1e6), std::lround(p.y() * 1e6), std::lround(p.z() * 1e6));
  };
  std::map<std::tuple<long, long, long>, Eigen::Vector3f> normals;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f n = (mesh.positions[t[1]] - mesh.positions[t[0]])
                                  .cross(mesh.positions[t[2]] - mesh.positions[t[0]]);  // area-weighted
    for (int k = 0; k < 3; ++k) {
      auto [it, inserted] = normals.try_emplace(key(mesh.positions[t[k]]), Eigen::Vector3f::Zero());
      it->second += n;
    }
  }
  for (Eigen::Vector3f& p : mesh.positions) p += static_cast<float>(offset_m) * normals[key(p)].normalized();
  mesh.normals.clear();
  mesh.ComputeVertexNormals();
}

}  // namespace

ModelOptions SmallModel() {
  ModelOptions m;
  m.texture_resolution_px = 128;
  m.channels_per_basis = 4;
  m.ngf = 16;
  m.n_blocks = 3;
  m.mask_ngf = 8;
  m.mask_n_blocks = 2;
  return m;
}

void MakeTestWorkspace(const std::string& dir, const TestWorkspaceOptions& o) {
  fs::remove_all(dir);
  fs::create_directories(fs::path(dir) / "calib" / "undistorted" / "view");
  fs::create_directories(fs::path(dir) / "reconstruct" / "mattes");
  synth::SynthOptions options = synth::SynthOptions::ForSize("tiny");
  options.out = dir;
  const synth::SynthScene scene = synth::BuildScene("spot", options.board, synth::DefaultAssetsDir());
  const synth::CapturePlan plan = synth::MakeCapturePlan(options, scene);

  render::TriangleMesh proxy;
  for (const synth::SynthObject& object : scene.objects) {
    if (!object.foreground) continue;
    if (!object.mesh.has_uvs()) throw std::runtime_error("test workspace: the spot mesh has no UVs");
    proxy = object.mesh;
    break;
  }
  Inflate(proxy, o.proxy_offset_m);
  render::SaveMesh((fs::path(dir) / "reconstruct" / "proxy.obj").string(), proxy);

  const Intrinsics pinhole = plan.view_intrinsics.WithoutDistortion().Scaled(
      o.width_px, o.width_px * plan.view_intrinsics.height / plan.view_intrinsics.width);
  CamerasFile cameras;
  cameras.board = options.board;
  cameras.devices["view"] = pinhole;
  cameras.undistorted_view = pinhole;
  LightsFile lights;
  ProxyFile proxy_file;
  proxy_file.mesh = "reconstruct/proxy.obj";
  proxy_file.atlas_resolution_px = 256;
  const Eigen::AlignedBox3f bounds = proxy.Bounds();
  proxy_file.object_centre_m = bounds.center().cast<double>();
  proxy_file.object_radius_m = 0.5 * bounds.diagonal().norm();

  render::Scene render_scene;
  scene.AddTo(&render_scene);
  const int count = static_cast<int>(plan.view.frames.size());
  for (int i = 0; i < o.frames; ++i) {
    const synth::FramePlan& f = plan.view.frames[static_cast<size_t>(i) * count / o.frames];
    render_scene.ClearLights();
    render_scene.AddLight(render::PointLight{
        f.light_position_world.cast<float>(), render::Rgb::Constant(static_cast<float>(options.flash_intensity_w_per_sr))});
    if (i == 0) render_scene.Commit();
    char name[32];
    std::snprintf(name, sizeof(name), "view/%06d", i);
    CalibratedFrame frame;
    frame.name = name;
    frame.device = "view";
    frame.time_s = f.t_common_s;
    frame.cam_from_world = f.cam_from_world;
    frame.image_linear = "calib/undistorted/" + std::string(name) + ".exr";
    render::RenderOptions ro;
    ro.samples_per_pixel = o.samples_per_pixel;
    ro.max_depth = 3;
    ro.seed = static_cast<uint64_t>(i + 1);
    ro.alpha_object_ids = scene.ForegroundIds();
    const render::RenderResult result = render::RenderImage(render_scene, cameras.ViewCamera(frame), ro);
    WriteImage((fs::path(dir) / frame.image_linear).string(), result.radiance);
    const std::string matte = "reconstruct/mattes/" + fs::path(name).filename().string() + ".png";
    WriteImage((fs::path(dir) / matte).string(), result.alpha, PixelStorage::kUint16);
    cameras.frames.push_back(frame);
    FrameLight light;
    light.view_frame = name;
    light.time_s = f.t_common_s;
    light.position_m = f.light_position_world;
    lights.frames.push_back(light);
    proxy_file.mattes.push_back({name, matte, ""});
  }
  WriteCamerasFile((fs::path(dir) / "calib" / "cameras.json").string(), cameras);
  WriteLightsFile((fs::path(dir) / "calib" / "lights.json").string(), lights);
  WriteProxyFile((fs::path(dir) / "reconstruct" / "proxy.json").string(), proxy_file);
}

std::string WriteTestTruth(const std::string& dir, bool render_images, int width_px, int height_px) {
  synth::SynthOptions options = synth::SynthOptions::ForSize("tiny");  // as MakeTestWorkspace
  options.out = dir;
  options.eval_noise_halves = false;  // one render per image here
  const synth::SynthScene scene = synth::BuildScene("spot", options.board, synth::DefaultAssetsDir());
  synth::CapturePlan plan = synth::MakeCapturePlan(options, scene);
  plan.eval_intrinsics = plan.eval_intrinsics.Scaled(width_px, height_px);
  const std::string truth = dir + "/truth.json";
  // No videos here: only the evaluation set (below) stands in for a render.
  WriteJsonFile(truth, synth::kTruthKind, synth::kTruthVersion,
                synth::MakeTruthJson(options, scene, plan, synth::RenderedParts{false, true}));
  const Image sky = render::MakeSkyMap(options.envmap_width_px, plan.sun_elevation_rad, plan.sun_azimuth_rad);
  const Image studio = render::MakeStudioMap(options.envmap_width_px);
  fs::create_directories(dir + "/eval/envmaps");
  WriteImage(dir + "/" + synth::EnvmapPath("sky"), sky, PixelStorage::kFloat);
  WriteImage(dir + "/" + synth::EnvmapPath("studio"), studio, PixelStorage::kFloat);
  render::Scene render_scene;
  scene.AddTo(&render_scene);
  bool committed = false;
  for (size_t v = 0; v < plan.eval_views.size(); ++v) {
    fs::create_directories(dir + "/eval/" + plan.eval_views[v].name);
    for (size_t l = 0; l < plan.eval_lights.size(); ++l) {
      const synth::EvalLight& light = plan.eval_lights[l];
      const std::string image = dir + "/" + synth::EvalImagePath(plan.eval_views[v].name, light.name);
      const std::string alpha = dir + "/" + synth::EvalAlphaPath(plan.eval_views[v].name);
      if (!render_images) {
        WriteImage(image, Image(1, 1, 3));
        WriteImage(alpha, Image(1, 1, 1));
        continue;
      }
      render_scene.ClearLights();
      if (light.type == "point") {
        render_scene.AddLight(render::PointLight{light.position_world.cast<float>(), light.rgb.cast<float>().array()});
      } else if (light.type == "directional") {
        render_scene.AddLight(
            render::DirectionalLight{light.direction_to_light.cast<float>(), light.rgb.cast<float>().array()});
      } else {
        render_scene.SetEnvironment(render::EnvironmentLight(light.envmap == "sky" ? sky : studio));
      }
      if (!committed) render_scene.Commit();
      committed = true;
      render::RenderOptions ro;
      ro.samples_per_pixel = 16;
      ro.max_depth = options.max_depth;
      ro.seed = 100 + v * 10 + l;
      ro.alpha_object_ids = scene.ForegroundIds();
      const render::RenderResult result =
          render::RenderImage(render_scene, Camera(plan.eval_intrinsics, plan.eval_views[v].cam_from_world), ro);
      WriteImage(image, result.radiance);
      if (l == 0) WriteImage(alpha, result.alpha);
    }
  }
  return truth;
}

}  // namespace relit::relight::testing
