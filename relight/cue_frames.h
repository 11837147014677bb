// Cue frames: the networks' per-pixel light input for one view under one
// light, plus what the neural texture needs to be projected into the view.
// One half-float multi-channel EXR per frame; its light channels depend on
// the CueFormat (`cues.input`, `cues.bases`):
//   input radiance: cue0.R cue0.G cue0.B ... (3 per basis material, linear RGB
//                   radiance cues; default 5 bases = 15 channels)
//   input sh:       shv0..shv8 (SH of the view direction), shl0..shl8 (SH of
//                   the light direction), level.R level.G level.B (light
//                   level, sh_encoding.h): a G-buffer, no path tracing
// followed by
//   u v                               atlas coordinates (OBJ convention, v up)
//   dudx dvdx dudy dvdy               their screen-space derivatives (per pixel)
//   A                                 proxy coverage (fraction of the pixel)
// The same function renders training frames (`cues`) and new views
// (`render`), so both see identical inputs.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/scene.h"
#include "relight/support_plane.h"

namespace relit::relight {

// Object id of the proxy in cue scenes (alpha, uv); other objects are context.
constexpr int kProxyObjectId = 1;

// What a cue frame holds for the networks (docs/relight.md, "Baselines").
struct CueFormat {
  static constexpr const char* kRadiance = "radiance";  // DNL radiance cues
  static constexpr const char* kSh = "sh";              // DNR-style SH encoding
  std::string input = kRadiance;
  // Basis materials of the radiance cues, names of render::DefaultCueBasis()
  // ("lambert", "ggx_0.02", "ggx_0.05", "ggx_0.13", "ggx_0.34"). Unused by sh.
  std::vector<std::string> bases = DefaultBasisNames();

  static std::vector<std::string> DefaultBasisNames();
  bool is_sh() const { return input == kSh; }
  bool is_default() const { return input == kRadiance && bases == DefaultBasisNames(); }
  // Light channels per pixel: 3 x bases (radiance) or 21 (sh).
  int light_channels() const;
  // All channel names of a frame, in file order (light channels, then the
  // 7 geometry channels u v dudx dvdx dudy dvdy A).
  std::vector<std::string> Channels() const;
  // "ggx_0.02" -> "ggx_alpha_0.02": the spelling of the `basis` key of
  // cues.json and the asset manifest (empty for sh).
  std::vector<std::string> LongBasisNames() const;
  // "radiance cues, 5 bases (lambert, ...)" / "sh" for messages.
  std::string Describe() const;
  // Throws relit::Error for unknown inputs or basis names, duplicates, none.
  void Check() const;
  // {"input": .., "bases": [..]} (bases only for radiance).
  nlohmann::json ToJson() const;
  // From ToJson's form; missing keys keep the defaults (files of older relit).
  static CueFormat FromJson(const nlohmann::json& j, const std::string& where);
  bool operator==(const CueFormat& o) const { return input == o.input && (is_sh() || bases == o.bases); }
  bool operator!=(const CueFormat& o) const { return !(*this == o); }
};

// Channel names of a default-format cue frame (5 radiance cues), file order.
const std::vector<std::string>& CueFrameChannels();
constexpr int kCueChannelCount = 15;  // default: 5 bases x RGB
constexpr int kGeometryChannelCount = 7;  // u v dudx dvdx dudy dvdy A

struct CueRenderSettings {
  int samples_per_pixel = 16;
  int max_depth = 4;
  uint64_t seed = 1;
  // Filter the cues' path-tracing noise (render::DenoiseCues): all of an
  // environment map's or area light's cues; of a point or directional
  // light's, all but its direct light at the primary hit, which is exact.
  bool denoise = false;
};

// A light for cue rendering. Units as core/render/light.h.
struct CueLight {
  enum class Kind { kPoint, kDirectional, kEnvironment, kQuad };
  Kind kind = Kind::kPoint;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();         // point
  Eigen::Vector3d direction_to_light = Eigen::Vector3d::UnitZ();  // directional
  Eigen::Vector3d color = Eigen::Vector3d::Ones();               // intensity / irradiance / radiance
  render::EnvironmentLight environment;                          // environment
  render::QuadLight quad;                                        // area

  static CueLight Point(const Eigen::Vector3d& position_m, double intensity);
  nlohmann::json ToJson() const;
};

// Reads a cue frame and returns its channels in CueFrameChannels() order
// (EXR files store channels sorted by name). Throws relit::Error naming the
// file and the missing channel.
Image ReadCueFrame(const std::string& path, const CueFormat& format = {});

// The proxy mesh (OBJ with UVs, world frame) as a cue scene, shaded with
// its normal map when `normal_map_path` names one (reconstruct's
// proxy_normals.exr; "" = the mesh normals). With `cue_weights_path` (the
// cue stage's proxy_cue_weights.exr, cues.secondary_material fitted) the
// proxy wears past the primary hit the mixture of the 5 default bases those
// weights give (render::Material::cue_weights). Throws relit::Error naming
// the file when it cannot be read, has no UVs or lacks a weight channel.
std::unique_ptr<render::Scene> LoadProxyScene(const std::string& mesh_path, const SupportPlane& plane = {},
                                              const std::string& normal_map_path = "",
                                              const std::string& cue_weights_path = "");

// The fitted cue weights' file: 15 float channels cue0.R .. cue4.B (the
// weight of each default basis per colour), rows from v = 1, as
// CueTextureFit::Weight. Throws relit::Error naming the file.
Image ReadCueWeights(const std::string& path);

// Renders one cue frame (channels as format.Channels()). Replaces the
// scene's lights with `light`. Not thread-safe for the same scene (the
// rendering itself runs in parallel). The sh format traces primary rays
// only (coverage with settings.samples_per_pixel, geometry at the pixel
// centre) and supports point, directional and environment lights.
Image RenderCueFrame(render::Scene& scene, const Camera& camera, const CueLight& light,
                     const CueRenderSettings& settings, const CueFormat& format = {});

}  // namespace relit::relight
