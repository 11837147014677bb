// The fixed scene of the path tracer benchmark, and RenderImage observed so
// every ray it traces is counted (and optionally recorded).
//
// Scene: the Spot cow (bench/assets/spot.obj, +Y up in the file) rotated to
// relit's +Z-up world and standing on z = 0, a Lambert ground quad, one
// point light, a pinhole camera at a fixed pose. The same description is
// handed to Blender (bench/cycles_scene.py) so Cycles renders the same scene.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera.h"
#include "core/image.h"
#include "core/render/path_tracer.h"
#include "core/render/scene.h"

namespace relit::bench {

using render::Rgb;
using render::Vec3f;

enum class CowMaterial { kLambert, kGgx };
const char* MaterialName(CowMaterial material);

// Everything both renderers need to build the scene. Units: metres, radians,
// W/sr for the point light.
struct BenchSceneSpec {
  std::string mesh_path;
  int width = 320;
  int height = 240;
  Eigen::Vector3d camera_eye{3.0, 3.4, 1.7};
  Eigen::Vector3d camera_target{0.0, 0.1, 0.7};
  double horizontal_fov_rad = 40.0 * 3.14159265358979323846 / 180.0;
  Vec3f light_position{2.0f, 1.5f, 3.5f};
  float light_intensity = 12.0f;    // W/sr, white
  float ground_half_size = 4.0f;    // ground quad spans [-h, h]^2 at z = 0
  float ground_albedo = 0.5f;       // Lambert
  float lambert_albedo = 0.8f;      // cow, Lambert variant
  float ggx_albedo = 0.8f;          // cow, GGX variant: specular colour, Fresnel = 1
  float ggx_alpha = 0.2f;           // GGX alpha (Blender roughness = sqrt(alpha))

  // Filled by LoadBenchMesh: world_from_object of the cow (+Y up -> +Z up,
  // feet on z = 0).
  Eigen::Affine3f cow_world_from_object = Eigen::Affine3f::Identity();

  Camera MakeCamera() const;
};

constexpr int kCowObjectId = 1;
constexpr int kGroundObjectId = 2;

// Loads the cow, replaces its normals by angle-weighted vertex normals welded
// across UV seams (what Blender's smooth shading uses), and sets
// spec->cow_world_from_object.
render::TriangleMesh LoadBenchMesh(BenchSceneSpec* spec);

// Builds and commits the relit scene for one cow material.
void BuildRelitScene(const BenchSceneSpec& spec, const render::TriangleMesh& cow,
                     CowMaterial material, render::Scene* scene);

// A ray as Embree sees it. `occlusion` marks shadow rays (rtcOccluded1).
struct RecordedRay {
  float origin[3];
  float direction[3];
  float t_min;
  float t_max;
  uint32_t occlusion;
};

struct RayCounts {
  uint64_t intersected = 0;  // rtcIntersect1: camera, continuation and AOV rays
  uint64_t occluded = 0;     // rtcOccluded1: next-event shadow rays
  uint64_t Total() const { return intersected + occluded; }
};

struct ObservedRender {
  Image radiance;
  RayCounts counts;
  // Empty unless recorded; grouped by rendering thread.
  std::vector<RecordedRay> rays;
};

// RenderImage with a ray observer on the scene: counts every ray the
// renderer traces and optionally records them for the bare-Embree replay.
ObservedRender RenderObserved(render::Scene& scene, const Camera& camera, const render::RenderOptions& options,
                              bool record_rays);

// Largest absolute per-channel difference of two images of the same size.
float MaxAbsDifference(const Image& a, const Image& b);

}  // namespace relit::bench
