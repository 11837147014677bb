// Procedural environment maps (equirectangular, +Z up, linear RGB; layout as
// render::EnvironmentLight: row 0 = zenith, u = atan2(y, x) / 2pi).
#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "core/image.h"

namespace relit::render {

// Clear sky: blue zenith fading to a pale horizon, dim ground below the
// horizon, a glow around the sun and a small, very bright sun disc.
// Sun irradiance (perpendicular) is about 3x the sky's on a horizontal plane.
Image MakeSkyMap(int width_px, double sun_elevation_rad, double sun_azimuth_rad);

// Dark studio with three soft-edged coloured area lights (warm key, cool
// fill, magenta rim) and a dim floor.
Image MakeStudioMap(int width_px);

// Soft, smooth indoor ambient (bright ceiling, a broad window glow, dim
// floor): the lighting of the geometry pass.
Image MakeSoftRoomMap(int width_px);

// One of a family of varied procedural maps for lighting augmentation
// (relight/augment.h): no map collection can be downloaded, so relit makes
// its own. Index i of the family seeded by `seed` is, by i % 3,
//   0 "sky":    sun anywhere from 3 to 85 deg elevation, haze (turbidity)
//               whitening the sky and warming a low sun;
//   1 "studio": 2-5 soft-edged rectangular area lights of random size,
//               place and colour over a dim room;
//   2 "smooth": a few broad coloured Gaussian lobes over a soft gradient.
// Deterministic in (seed, index); `name` is e.g. "sky_012".
struct ProceduralEnvironment {
  std::string name;
  Image map;
};
ProceduralEnvironment MakeAugmentationMap(int width_px, uint64_t seed, int index);

// Unit direction (world, +Z up) through the centre of pixel (x, y) of a map
// of the given size.
Eigen::Vector3d EnvironmentPixelDirection(int x, int y, int width_px, int height_px);

}  // namespace relit::render
