#include "core/render/envmaps.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "core/error.h"
#include "core/render/sampling.h"

namespace relit::render {

namespace {

Eigen::Vector3d SphericalDirection(double elevation_rad, double azimuth_rad) {
  return {std::cos(elevation_rad) * std::cos(azimuth_rad),
          std::cos(elevation_rad) * std::sin(azimuth_rad), std::sin(elevation_rad)};
}

double SmoothStep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

Image Fill(int width_px, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& radiance) {
  RELIT_REQUIRE(width_px >= 16 && width_px % 2 == 0, "environment map width must be even and >= 16, got ",
                width_px);
  const int height_px = width_px / 2;
  Image map(width_px, height_px, 3);
  for (int y = 0; y < height_px; ++y) {
    for (int x = 0; x < width_px; ++x) {
      const Eigen::Vector3d value = radiance(EnvironmentPixelDirection(x, y, width_px, height_px));
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = static_cast<float>(value[c]);
    }
  }
  return map;
}

// A soft-edged rectangle in (elevation, azimuth) around a centre direction.
double SoftBox(const Eigen::Vector3d& d, double elevation_rad, double azimuth_rad,
               double half_height_rad, double half_width_rad) {
  const double elevation = std::asin(std::clamp(d.z(), -1.0, 1.0));
  double azimuth = std::atan2(d.y(), d.x()) - azimuth_rad;
  azimuth = std::remainder(azimuth, 2 * M_PI);
  const double soft = 0.03;
  return SmoothStep(half_height_rad + soft, half_height_rad - soft, std::abs(elevation - elevation_rad)) *
         SmoothStep(half_width_rad + soft, half_width_rad - soft, std::abs(azimuth));
}

}  // namespace

Eigen::Vector3d EnvironmentPixelDirection(int x, int y, int width_px, int height_px) {
  const double phi = 2 * M_PI * (x + 0.5) / width_px;
  const double theta = M_PI * (y + 0.5) / height_px;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

namespace {

// Turbidity 0 = the clear default sky; 1 = heavy haze (pale sky, bright
// horizon, warm dim sun).
Image MakeHazySkyMap(int width_px, double sun_elevation_rad, double sun_azimuth_rad, double turbidity) {
  const Eigen::Vector3d sun = SphericalDirection(sun_elevation_rad, sun_azimuth_rad);
  const Eigen::Vector3d white(0.6, 0.62, 0.65);
  const Eigen::Vector3d zenith_rgb = (1 - turbidity) * Eigen::Vector3d(0.12, 0.25, 0.60) + turbidity * white;
  const Eigen::Vector3d horizon_rgb = (1 + turbidity) * Eigen::Vector3d(0.55, 0.62, 0.70);
  const Eigen::Vector3d ground_rgb(0.09, 0.08, 0.065);
  // A low or hazy sun goes orange (more air to cross).
  const double warm = std::clamp(turbidity * 0.5 + (1 - std::sin(std::max(sun_elevation_rad, 0.0))) * 0.6, 0.0, 1.0);
  const Eigen::Vector3d sun_rgb = (1 - warm) * Eigen::Vector3d(1.0, 0.93, 0.82) + warm * Eigen::Vector3d(1.0, 0.62, 0.32);
  // Sun disc of 1.5 deg radius; keep its solid angle resolved by >= 3 pixels.
  const double sun_radius_rad = std::max(0.0262, 3.0 * M_PI / (width_px / 2));
  const double sun_solid_angle_sr = 2 * M_PI * (1 - std::cos(sun_radius_rad));
  const double sun_irradiance = 2.5 * (1 - 0.6 * turbidity);  // W/m^2-equivalent, perpendicular to the sun
  const double sun_radiance = sun_irradiance / sun_solid_angle_sr;
  return Fill(width_px, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    const double cos_sun = std::clamp(d.dot(sun), -1.0, 1.0);
    const double angle_to_sun = std::acos(cos_sun);
    Eigen::Vector3d value;
    if (d.z() >= 0) {
      const double t = std::pow(d.z(), 0.45);
      value = (1 - t) * horizon_rgb + t * zenith_rgb;
      value += 0.6 * std::exp(-angle_to_sun / 0.15) * sun_rgb;   // aureole
      value += 0.15 * std::pow(std::max(0.0, cos_sun), 4) * sun_rgb;
      if (angle_to_sun < sun_radius_rad) value += sun_radiance * sun_rgb;
    } else {
      value = ground_rgb * (1.0 + 0.5 * std::exp(d.z() / 0.1));  // brighter towards the horizon
    }
    return value;
  });
}

}  // namespace

Image MakeSkyMap(int width_px, double sun_elevation_rad, double sun_azimuth_rad) {
  return MakeHazySkyMap(width_px, sun_elevation_rad, sun_azimuth_rad, 0.0);
}

Image MakeStudioMap(int width_px) {
  struct Box {
    double elevation_deg, azimuth_deg, half_height_deg, half_width_deg;
    Eigen::Vector3d radiance;
  };
  const Box boxes[] = {
      {40, 30, 12, 16, {7.0, 5.6, 3.6}},     // warm key
      {15, 150, 14, 20, {1.2, 1.8, 3.2}},    // cool fill
      {55, 255, 18, 7, {4.5, 1.2, 4.0}},     // magenta rim
      {70, 100, 6, 25, {1.0, 2.6, 1.2}},     // small green strip
  };
  return Fill(width_px, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    Eigen::Vector3d value = d.z() >= 0 ? Eigen::Vector3d(0.025, 0.025, 0.03)
                                       : Eigen::Vector3d(0.05, 0.045, 0.04);
    for (const Box& box : boxes) {
      value += SoftBox(d, box.elevation_deg * M_PI / 180, box.azimuth_deg * M_PI / 180,
                       box.half_height_deg * M_PI / 180, box.half_width_deg * M_PI / 180) *
               box.radiance;
    }
    return value;
  });
}

Image MakeSoftRoomMap(int width_px) {
  const Eigen::Vector3d window = SphericalDirection(0.35, 0.7);
  return Fill(width_px, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    const Eigen::Vector3d warm(1.0, 0.95, 0.88), cool(0.85, 0.92, 1.0);
    Eigen::Vector3d value = (0.35 + 0.4 * std::max(0.0, d.z())) * warm;
    if (d.z() < 0) value = 0.15 * warm * (1.0 + d.z() * 0.3);
    value += 0.5 * std::exp((d.dot(window) - 1.0) / 0.35) * cool;  // broad window glow
    return value;
  });
}

ProceduralEnvironment MakeAugmentationMap(int width_px, uint64_t seed, int index) {
  RELIT_REQUIRE(index >= 0, "augmentation map index must be >= 0, got ", index);
  Rng rng(seed, static_cast<uint64_t>(index) + 1);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * rng.Uniform(); };
  // A saturated-to-pastel colour of random hue, unit maximum.
  auto colour = [&](double max_saturation) {
    const double hue = uniform(0, 6), saturation = uniform(0, max_saturation);
    const double f = hue - std::floor(hue);
    const double p = 1 - saturation, q = 1 - saturation * f, t = 1 - saturation * (1 - f);
    switch (static_cast<int>(hue) % 6) {
      case 0: return Eigen::Vector3d(1, t, p);
      case 1: return Eigen::Vector3d(q, 1, p);
      case 2: return Eigen::Vector3d(p, 1, t);
      case 3: return Eigen::Vector3d(p, q, 1);
      case 4: return Eigen::Vector3d(t, p, 1);
      default: return Eigen::Vector3d(1, p, q);
    }
  };
  char name[32];
  ProceduralEnvironment result;
  switch (index % 3) {
    case 0: {
      std::snprintf(name, sizeof(name), "sky_%03d", index);
      result.map = MakeHazySkyMap(width_px, uniform(3, 85) * M_PI / 180, uniform(0, 2 * M_PI), uniform(0, 0.8));
      break;
    }
    case 1: {
      std::snprintf(name, sizeof(name), "studio_%03d", index);
      struct Box {
        double elevation, azimuth, half_height, half_width;
        Eigen::Vector3d radiance;
      };
      std::vector<Box> boxes(2 + static_cast<int>(rng.Uniform() * 4));
      for (Box& b : boxes) {
        b = {uniform(-5, 75) * M_PI / 180, uniform(0, 2 * M_PI), uniform(4, 20) * M_PI / 180,
             uniform(4, 25) * M_PI / 180, uniform(1, 8) * colour(0.8)};
      }
      const double ambient = uniform(0.01, 0.06);
      result.map = Fill(width_px, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
        Eigen::Vector3d value = Eigen::Vector3d::Constant(d.z() >= 0 ? ambient : 1.5 * ambient);
        for (const Box& b : boxes) value += SoftBox(d, b.elevation, b.azimuth, b.half_height, b.half_width) * b.radiance;
        return value;
      });
      break;
    }
    default: {
      std::snprintf(name, sizeof(name), "smooth_%03d", index);
      struct Lobe {
        Eigen::Vector3d direction, radiance;
        double width;
      };
      std::vector<Lobe> lobes(2 + static_cast<int>(rng.Uniform() * 4));
      for (Lobe& l : lobes) {
        l = {SphericalDirection(uniform(-20, 85) * M_PI / 180, uniform(0, 2 * M_PI)), uniform(0.5, 4) * colour(0.9),
             uniform(0.15, 0.8)};
      }
      const Eigen::Vector3d top = uniform(0.05, 0.4) * colour(0.5), bottom = uniform(0.02, 0.15) * colour(0.5);
      result.map = Fill(width_px, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
        const double t = 0.5 * (d.z() + 1);
        Eigen::Vector3d value = t * top + (1 - t) * bottom;
        for (const Lobe& l : lobes) value += std::exp((d.dot(l.direction) - 1) / (l.width * l.width)) * l.radiance;
        return value;
      });
      break;
    }
  }
  result.name = name;
  return result;
}

}  // namespace relit::render
