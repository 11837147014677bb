// Light sources. Units: point light intensity in W/sr (radiance units x m^2),
// directional light irradiance on a perpendicular surface, area and
// environment lights in radiance. All positions/directions in world space.
#pragma once

#include <memory>
#include <string>

#include "core/image.h"
#include "core/render/sampling.h"

namespace relit::render {

struct PointLight {
  Vec3f position = Vec3f::Zero();  // metres
  Rgb intensity = Rgb::Ones();
};

struct DirectionalLight {
  Vec3f direction_to_light = Vec3f::UnitZ();  // unit vector towards the light
  Rgb irradiance = Rgb::Ones();
};

// One-sided emissive parallelogram: corner + s*edge_u + t*edge_v, s,t in [0,1],
// emitting towards normalize(edge_u x edge_v).
struct QuadLight {
  Vec3f corner = Vec3f::Zero();
  Vec3f edge_u = Vec3f::UnitX();
  Vec3f edge_v = Vec3f::UnitY();
  Rgb radiance = Rgb::Ones();
  Vec3f Normal() const { return edge_u.cross(edge_v).normalized(); }
  float Area() const { return edge_u.cross(edge_v).norm(); }
};

// Equirectangular environment map, +Z up: a direction with polar angle theta
// (from +Z) and azimuth phi = atan2(y, x) maps to u = phi / (2 pi) wrapped to
// [0, 1) and v = theta / pi (v = 0 at the zenith, the top image row).
class EnvironmentLight {
 public:
  EnvironmentLight() = default;
  // `map` must have at least 3 channels (linear RGB); `scale` multiplies it;
  // `rotation_z_rad` turns the map about +Z.
  EnvironmentLight(const Image& map, float scale = 1.0f, float rotation_z_rad = 0.0f);
  static EnvironmentLight FromFile(const std::string& path, float scale = 1.0f,
                                   float rotation_z_rad = 0.0f);

  bool valid() const { return map_ != nullptr; }
  Rgb Eval(const Vec3f& direction_world) const;  // bilinear lookup
  // Importance sample by luminance x sin(theta); pdf in solid angle.
  Vec3f Sample(const Vec2f& u, float* pdf) const;
  float Pdf(const Vec3f& direction_world) const;

  static Vec2f DirectionToUv(const Vec3f& d);
  static Vec3f UvToDirection(const Vec2f& uv);
  const Image& map() const { return *map_; }

 private:
  std::shared_ptr<const Image> map_;
  float scale_ = 1.0f;
  float rotation_z_rad_ = 0.0f;
  Distribution2D distribution_;
};

}  // namespace relit::render
