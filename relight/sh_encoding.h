// Light input of the spherical-harmonics baseline (cues.input: sh), a
// Deferred Neural Rendering (Thies et al. 2019) renderer extended to the
// light direction, as the DNL thesis' comparison (section 4.6.2).
//
// Per pixel of the proxy (world position P, camera centre C):
//   shv_k   = Y_k(normalize(C - P))                  view direction, k = 0..8
//   shl_k   = Y_k(normalize(L - P))                  point light at L
//           = Y_k(d)                                  directional light towards d
//           = int L(w) Y_k(w) dw / int L(w) dw        environment map (luminance),
//             which equals Y_k(d) for all light from one direction d
//   level   = I / |L - P|^2 (point, RGB), E (directional), int L(w) dw (map):
//             the light arriving at P from all directions, without the cosine
//             (no normals are used: the network learns shading, as in DNR)
// Y_k are the real, orthonormal spherical harmonics of bands 0..2 (9
// coefficients, the "3rd order" Thies et al. used), without the
// Condon-Shortley phase, in the order (l, m) = (0,0), (1,-1), (1,0), (1,1),
// (2,-2), (2,-1), (2,0), (2,1), (2,2). Visibility (shadows) is not encoded:
// the network has to learn it from the directions, as DNR does.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "relight/cue_frames.h"

namespace relit::relight {

constexpr int kShCoefficientCount = 9;  // bands 0..2
// shv0..8, shl0..8, level.R/G/B.
constexpr int kShLightChannelCount = 2 * kShCoefficientCount + 3;

// Y_k(direction) for a unit direction (world frame; any frame works as long
// as training and rendering agree).
std::array<double, kShCoefficientCount> ShBasis(const Eigen::Vector3d& direction);

// Channel names of the sh light input, file order.
const std::vector<std::string>& ShLightChannelNames();

// A light reduced to what the sh input needs. Environment maps are projected
// once (numerical quadrature over the sphere).
struct ShLight {
  CueLight::Kind kind = CueLight::Kind::kPoint;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // point
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();   // directional, unit
  Eigen::Vector3d color = Eigen::Vector3d::Ones();        // intensity (point) or level (others)
  std::array<double, kShCoefficientCount> coefficients{}; // environment: normalised projection

  // Throws relit::Error for area lights (not defined for this baseline).
  static ShLight FromCueLight(const CueLight& light);
  // The 21 light channels at world point `point_m` seen from `camera_centre_m`.
  void PixelFeatures(const Eigen::Vector3d& point_m, const Eigen::Vector3d& camera_centre_m, float* out) const;
};

// int L(w) Y_k(w) dw (per RGB channel: [k][c]) and int L(w) dw (RGB) of an
// environment light, by the midpoint rule on a theta x phi grid of
// `rows` x 2 rows cells.
struct ShProjection {
  std::array<Eigen::Vector3d, kShCoefficientCount> coefficients;
  Eigen::Vector3d integral = Eigen::Vector3d::Zero();
};
ShProjection ProjectEnvironment(const render::EnvironmentLight& environment, int rows = 128);

}  // namespace relit::relight
