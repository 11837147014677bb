#include "relight/cue_frames.h"

#include <algorithm>
#include <filesystem>
#include <numeric>

#include "core/error.h"
#include "core/render/cue_denoise.h"
#include "core/render/cue_renderer.h"
#include "core/render/path_tracer.h"
#include "relight/sh_encoding.h"

namespace relit::relight {

namespace {

const char* const kGeometryChannels[kGeometryChannelCount] = {"u", "v", "dudx", "dvdx", "dudy", "dvdy", "A"};

// The basis materials of `names`, in that order.
std::vector<render::CueBasis> SelectBases(const std::vector<std::string>& names) {
  const std::vector<render::CueBasis> all = render::DefaultCueBasis();
  std::vector<render::CueBasis> selected;
  for (const std::string& name : names) {
    auto it = std::find_if(all.begin(), all.end(), [&](const render::CueBasis& b) { return b.name == name; });
    RELIT_CHECK(it != all.end());  // CueFormat::Check ran
    selected.push_back(*it);
  }
  return selected;
}

}  // namespace

std::vector<std::string> CueFormat::DefaultBasisNames() {
  std::vector<std::string> names;
  for (const render::CueBasis& b : render::DefaultCueBasis()) names.push_back(b.name);
  return names;
}

int CueFormat::light_channels() const {
  return is_sh() ? kShLightChannelCount : 3 * static_cast<int>(bases.size());
}

std::vector<std::string> CueFormat::Channels() const {
  std::vector<std::string> n =
      is_sh() ? ShLightChannelNames() : render::CueChannelNames(static_cast<int>(bases.size()));
  for (const char* extra : kGeometryChannels) n.push_back(extra);
  return n;
}

std::vector<std::string> CueFormat::LongBasisNames() const {
  std::vector<std::string> names;
  if (is_sh()) return names;
  for (const std::string& b : bases) names.push_back(b.rfind("ggx_", 0) == 0 ? "ggx_alpha_" + b.substr(4) : b);
  return names;
}

std::string CueFormat::Describe() const {
  if (is_sh()) return "sh (spherical-harmonics view and light encoding)";
  std::string s = "radiance cues, " + std::to_string(bases.size()) + (bases.size() == 1 ? " basis (" : " bases (");
  for (size_t i = 0; i < bases.size(); ++i) s += (i ? ", " : "") + bases[i];
  return s + ")";
}

void CueFormat::Check() const {
  RELIT_REQUIRE(input == kRadiance || input == kSh, "cues.input must be '", kRadiance, "' (DNL radiance cues) or '",
                kSh, "' (the spherical-harmonics baseline), got '", input, "'");
  if (is_sh()) return;
  const std::vector<std::string> known = DefaultBasisNames();
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  RELIT_REQUIRE(!bases.empty(), "cues.bases must name at least one basis material (", list, ")");
  for (size_t i = 0; i < bases.size(); ++i) {
    RELIT_REQUIRE(std::find(known.begin(), known.end(), bases[i]) != known.end(), "cues.bases: unknown basis '",
                  bases[i], "'; known: ", list);
    RELIT_REQUIRE(std::find(bases.begin(), bases.begin() + i, bases[i]) == bases.begin() + i,
                  "cues.bases: '", bases[i], "' is listed twice");
  }
}

nlohmann::json CueFormat::ToJson() const {
  nlohmann::json j = {{"input", input}};
  if (!is_sh()) j["bases"] = bases;
  return j;
}

CueFormat CueFormat::FromJson(const nlohmann::json& j, const std::string& where) {
  CueFormat f;
  RELIT_REQUIRE(j.is_object(), where, ": expected an object with 'input' and 'bases'");
  if (j.contains("input")) f.input = j["input"].get<std::string>();
  if (j.contains("bases")) f.bases = j["bases"].get<std::vector<std::string>>();
  try {
    f.Check();
  } catch (const Error& e) {
    Fail(where, ": ", e.what());
  }
  return f;
}

const std::vector<std::string>& CueFrameChannels() {
  static const std::vector<std::string> names = CueFormat{}.Channels();
  return names;
}

Image ReadCueFrame(const std::string& path, const CueFormat& format) {
  const Image image = ReadImage(path);
  const std::vector<std::string> channels = format.Channels();
  for (const std::string& name : channels) {
    RELIT_REQUIRE(image.ChannelIndex(name) >= 0, path, " has no channel '", name, "': not a cue frame of ",
                  format.Describe(), "; rerun `relit-relight cues` with the config the model uses");
  }
  return image.SelectChannels(channels);
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

Image ReadCueWeights(const std::string& path) {
  RELIT_REQUIRE(std::filesystem::exists(path), "proxy cue weights ", path,
                " do not exist: run `relit-relight cues` again");
  const Image image = ReadImage(path);
  const std::vector<std::string> channels = render::CueChannelNames(kCueChannelCount / 3);
  for (const std::string& name : channels) {
    RELIT_REQUIRE(image.ChannelIndex(name) >= 0, path, " has no channel '", name,
                  "': not a proxy cue weights file; run `relit-relight cues` again");
  }
  return image.SelectChannels(channels);
}

std::unique_ptr<render::Scene> LoadProxyScene(const std::string& mesh_path, const SupportPlane& plane,
                                              const std::string& normal_map_path,
                                              const std::string& cue_weights_path) {
  RELIT_REQUIRE(std::filesystem::exists(mesh_path), "proxy mesh ", mesh_path,
                " does not exist: run the reconstruct stage first");
  render::TriangleMesh mesh = render::LoadMesh(mesh_path);
  RELIT_REQUIRE(mesh.has_uvs(), "proxy mesh ", mesh_path,
                " has no texture coordinates: the neural texture needs the UV atlas of the reconstruct stage");
  if (!mesh.has_normals()) mesh.ComputeVertexNormals();
  auto scene = std::make_unique<render::Scene>();
  // The cue renderer ignores materials but for their normal map; object id 1
  // marks the proxy in alpha.
  render::Material material = render::Material::Lambert(render::Rgb::Constant(0.5f));
  if (!normal_map_path.empty()) {
    RELIT_REQUIRE(std::filesystem::exists(normal_map_path), "proxy normal map ", normal_map_path,
                  " does not exist: run the reconstruct stage again");
    material.normal_map = render::Texture::FromFile(normal_map_path, false);
  }
  if (!cue_weights_path.empty()) {
    const Image weights = ReadCueWeights(cue_weights_path);
    for (int k = 0; k < kCueChannelCount / 3; ++k) {
      material.cue_weights.push_back(render::Texture::FromImage(weights.SelectChannels({3 * k, 3 * k + 1, 3 * k + 2}), false));
    }
  }
  scene->AddObject(std::move(mesh), material, kProxyObjectId);
  AddSupportPlane(plane, scene.get());
  scene->Commit();
  return scene;
}

namespace {

// The channels after the light channels: uv, its screen derivatives, alpha.
// A pixel centre on a context object (the support plane) is background: no uv.
void WriteGeometryChannels(const render::RenderResult& result, int x, int y, float* geometry) {
  geometry[6] = result.alpha.at(x, y, 0);
  if (result.object_id.at(x, y, 0) != kProxyObjectId) {
    for (int c = 0; c < 6; ++c) geometry[c] = 0;
    return;
  }
  geometry[0] = result.uv.at(x, y, 0);
  geometry[1] = result.uv.at(x, y, 1);
  for (int c = 0; c < 4; ++c) geometry[2 + c] = result.uv_derivatives.at(x, y, c);
}

// The sh format: primary rays only (coverage, uv, positions), then the SH
// light channels per pixel from the pixel-centre surface point.
Image RenderShFrame(const render::Scene& scene, const Camera& camera, const CueLight& light,
                    const render::RenderOptions& options) {
  const ShLight sh = ShLight::FromCueLight(light);
  const render::RenderResult result = render::RenderWithIntegrator(
      scene, camera, options, {"unused"},
      [](const render::Vec3f&, const render::Vec3f&, const render::Hit*, render::Rng&, float*) {});
  const int width = result.alpha.width(), height = result.alpha.height();
  const Eigen::Vector3d centre = camera.Center();
  Image frame(width, height, CueFormat{CueFormat::kSh}.Channels());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      float* out = frame.pixel(x, y);
      if (result.object_id.at(x, y, 0) == kProxyObjectId) {  // 0 where the centre ray misses (coverage may be > 0)
        const Eigen::Vector3d p(result.position.at(x, y, 0), result.position.at(x, y, 1), result.position.at(x, y, 2));
        sh.PixelFeatures(p, centre, out);
      }
      WriteGeometryChannels(result, x, y, out + kShLightChannelCount);
    }
  }
  return frame;
}

}  // namespace

Image RenderCueFrame(render::Scene& scene, const Camera& camera, const CueLight& light,
                     const CueRenderSettings& settings, const CueFormat& format) {
  format.Check();
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
  options.alpha_object_ids = {kProxyObjectId};
  if (format.is_sh()) return RenderShFrame(scene, camera, light, options);
  const std::vector<render::CueBasis> bases = SelectBases(format.bases);
  for (const render::Scene::Instance& instance : scene.instances()) {
    const size_t fitted = scene.material(instance.material).cue_weights.size();
    RELIT_REQUIRE(fitted == 0 || fitted == bases.size(), "the proxy's fitted cue weights are for ", fitted,
                  " bases but the cues have ", bases.size(), " (", format.Describe(),
                  "): cues.secondary_material fitted needs the default bases");
  }
  // A point or directional light's direct light is exact and holds the hard
  // shadow edges: when denoising, it is rendered apart and left unfiltered.
  const bool direct_apart =
      settings.denoise && (light.kind == CueLight::Kind::kPoint || light.kind == CueLight::Kind::kDirectional);
  const render::RenderResult result = direct_apart ? render::RenderCuesDeltaDirectApart(scene, camera, options, bases)
                                                   : render::RenderCues(scene, camera, options, bases);
  const int light_channels = format.light_channels();
  Image filtered;
  if (settings.denoise) {
    std::vector<int> noisy(light_channels);
    std::iota(noisy.begin(), noisy.end(), 0);
    filtered = render::DenoiseCues(result, direct_apart ? result.radiance.SelectChannels(noisy) : result.radiance,
                                   {}, render::CueNormalSigmas(bases));
  }
  const Image& cue_image = settings.denoise ? filtered : result.radiance;
  const int width = result.radiance.width(), height = result.radiance.height();
  Image frame(width, height, format.Channels());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      float* out = frame.pixel(x, y);
      const float* cues = cue_image.pixel(x, y);
      for (int c = 0; c < light_channels; ++c) out[c] = cues[c];
      if (direct_apart) {
        const float* direct = result.radiance.pixel(x, y) + light_channels;
        for (int c = 0; c < light_channels; ++c) out[c] += direct[c];
      }
      WriteGeometryChannels(result, x, y, out + light_channels);
    }
  }
  return frame;
}

}  // namespace relit::relight
