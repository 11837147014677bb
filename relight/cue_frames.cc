#include "relight/cue_frames.h"

#include <filesystem>

#include "core/error.h"
#include "core/render/cue_renderer.h"
#include "core/render/path_tracer.h"

namespace relit::relight {

const std::vector<std::string>& CueFrameChannels() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = render::CueChannelNames(5);
    for (const char* extra : {"u", "v", "dudx", "dvdx", "dudy", "dvdy", "A"}) n.push_back(extra);
    return n;
  }();
  return names;
}

Image ReadCueFrame(const std::string& path) {
  const Image image = ReadImage(path);
  for (const std::string& name : CueFrameChannels()) {
    RELIT_REQUIRE(image.ChannelIndex(name) >= 0, path, " has no channel '", name,
                  "': not a cue frame of this relit version; rerun `relit-relight cues`");
  }
  return image.SelectChannels(CueFrameChannels());
}

CueLight CueLight::Point(const Eigen::Vector3d& position_m, double intensity) {
  CueLight light;
  light.kind = Kind::kPoint;
  light.position_m = position_m;
  light.color = Eigen::Vector3d::Constant(intensity);
  return light;
}

nlohmann::json CueLight::ToJson() const {
  auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  switch (kind) {
    case Kind::kPoint:
      return {{"type", "point"}, {"position_m", vec(position_m)}, {"intensity", vec(color)}};
    case Kind::kDirectional:
      return {{"type", "directional"}, {"direction_to_light", vec(direction_to_light)}, {"irradiance", vec(color)}};
    case Kind::kEnvironment:
      return {{"type", "environment"}};
    case Kind::kQuad:
      return {{"type", "area"}, {"corner_m", vec(quad.corner.cast<double>())},
              {"edge_u_m", vec(quad.edge_u.cast<double>())}, {"edge_v_m", vec(quad.edge_v.cast<double>())},
              {"radiance", vec(quad.radiance.cast<double>().matrix())}};
  }
  return {};
}

std::unique_ptr<render::Scene> LoadProxyScene(const std::string& mesh_path) {
  RELIT_REQUIRE(std::filesystem::exists(mesh_path), "proxy mesh ", mesh_path,
                " does not exist: run the reconstruct stage first");
  render::TriangleMesh mesh = render::LoadMesh(mesh_path);
  RELIT_REQUIRE(mesh.has_uvs(), "proxy mesh ", mesh_path,
                " has no texture coordinates: the neural texture needs the UV atlas of the reconstruct stage");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  auto scene = std::make_unique<render::Scene>();
  // The cue renderer ignores materials; object id 1 marks the proxy in alpha.
  scene->AddObject(std::move(mesh), render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene->Commit();
  return scene;
}

Image RenderCueFrame(render::Scene& scene, const Camera& camera, const CueLight& light,
                     const CueRenderSettings& settings) {
  const bool had_emitters = !scene.quad_lights().empty();
  scene.ClearLights();
  if (had_emitters && light.kind != CueLight::Kind::kQuad) scene.Commit();
  switch (light.kind) {
    case CueLight::Kind::kPoint:
      scene.AddLight(render::PointLight{light.position_m.cast<float>(), light.color.cast<float>().array()});
      break;
    case CueLight::Kind::kDirectional:
      scene.AddLight(render::DirectionalLight{light.direction_to_light.normalized().cast<float>(),
                                              light.color.cast<float>().array()});
      break;
    case CueLight::Kind::kEnvironment:
      RELIT_REQUIRE(light.environment.valid(), "environment light without a map");
      scene.SetEnvironment(light.environment);
      break;
    case CueLight::Kind::kQuad:
      scene.AddLight(light.quad);
      scene.Commit();  // emitters are geometry
      break;
  }
  render::RenderOptions options;
  options.samples_per_pixel = settings.samples_per_pixel;
  options.max_depth = settings.max_depth;
  options.seed = settings.seed;
  // The network sees the object only; an environment seen behind it is not a cue.
  options.environment_visible = false;
  options.alpha_object_ids = {1};
  const render::RenderResult result = render::RenderCues(scene, camera, options);
  const int width = result.radiance.width(), height = result.radiance.height();
  Image frame(width, height, CueFrameChannels());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      float* out = frame.pixel(x, y);
      const float* cues = result.radiance.pixel(x, y);
      for (int c = 0; c < kCueChannelCount; ++c) out[c] = cues[c];
      out[15] = result.uv.at(x, y, 0);
      out[16] = result.uv.at(x, y, 1);
      for (int c = 0; c < 4; ++c) out[17 + c] = result.uv_derivatives.at(x, y, c);
      out[21] = result.alpha.at(x, y, 0);
    }
  }
  return frame;
}

}  // namespace relit::relight
