// Procedural environment maps (equirectangular, +Z up, linear RGB; layout as
// render::EnvironmentLight: row 0 = zenith, u = atan2(y, x) / 2pi).
#pragma once

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

// Unit direction (world, +Z up) through the centre of pixel (x, y) of a map
// of the given size.
Eigen::Vector3d EnvironmentPixelDirection(int x, int y, int width_px, int height_px);

}  // namespace relit::render
