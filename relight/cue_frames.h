// Radiance-cue frames: the proxy rendered under one light with the 5 basis
// materials, plus what the neural texture needs to be projected into the
// view. One half-float multi-channel EXR per frame with the channels
//   cue0.R cue0.G cue0.B ... cue4.B   the 5 cues (linear RGB)
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

namespace relit::relight {

// Channel names of a cue frame, in file order.
const std::vector<std::string>& CueFrameChannels();
constexpr int kCueChannelCount = 15;  // 5 bases x RGB

struct CueRenderSettings {
  int samples_per_pixel = 16;
  int max_depth = 4;
  uint64_t seed = 1;
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
Image ReadCueFrame(const std::string& path);

// The proxy mesh (OBJ with UVs, world frame) as a cue scene. Throws
// relit::Error naming the file when it cannot be read or has no UVs.
std::unique_ptr<render::Scene> LoadProxyScene(const std::string& mesh_path);

// Renders one cue frame (channels as CueFrameChannels()). Replaces the
// scene's lights with `light`. Not thread-safe for the same scene (the
// rendering itself runs in parallel).
Image RenderCueFrame(render::Scene& scene, const Camera& camera, const CueLight& light,
                     const CueRenderSettings& settings);

}  // namespace relit::relight
