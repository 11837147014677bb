// How well a capture samples view and light directions. Deferred Neural
// Lighting learns appearance as a function of both; the thesis stresses that
// view and light directions must be spread over the hemisphere and
// decorrelated (the light must not simply travel with the camera). The
// statistics and the warning rule are documented in docs/report.md.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/option_fields.h"

namespace relit::report {

struct CoverageThresholds {
  double min_view_spread_deg = 25;            // spread of camera directions
  double min_light_spread_deg = 25;           // spread of light directions
  double min_relative_light_spread_deg = 15;  // spread of the light seen from the camera
  double min_view_light_angle_deg = 10;       // median angle between camera and light

  static const OptionFields<CoverageThresholds>& Fields();
};

struct CoverageStats {
  int frames = 0;
  // Angular spread of a set of directions: acos(|mean of the unit vectors|),
  // 0 for a single direction, 60 deg for directions uniform on a hemisphere.
  double view_spread_deg = 0;
  double light_spread_deg = 0;
  // Spread of the light direction expressed in a frame attached to the view
  // direction (z = view, x = horizontal): 0 when the light keeps the same
  // place relative to the camera (flash on the camera, or the two phones
  // walking in lockstep), however much both move.
  double relative_light_spread_deg = 0;
  double median_view_light_angle_deg = 0;
  // Occupied cells of the upper hemisphere, 8 azimuth x 3 elevation bands
  // (as calib_report.json), and occupied (view cell, light cell) pairs.
  int view_cells = 0;
  int light_cells = 0;
  int view_light_cell_pairs = 0;
  std::vector<std::string> warnings;  // empty: coverage is fine

  nlohmann::json ToJson() const;
};

// Spread as defined above; 0 for an empty set. Directions need not be unit.
double AngularSpreadDeg(const std::vector<Eigen::Vector3d>& directions);

// `light` in the frame attached to `view` (both need not be unit; result is
// unit): z along view, x horizontal (world +Z cross view; world +X when view
// is vertical), y = z cross x.
Eigen::Vector3d LightInViewFrame(const Eigen::Vector3d& view, const Eigen::Vector3d& light);

// Cell index (0..23) of a direction on the upper hemisphere; directions
// below the horizon count in the lowest band.
int HemisphereCell(const Eigen::Vector3d& direction);

// View and light directions of the same frames (equal lengths), pointing
// from the object centre to the camera centre and to the light.
CoverageStats ComputeCoverage(const std::vector<Eigen::Vector3d>& view_directions,
                              const std::vector<Eigen::Vector3d>& light_directions,
                              const CoverageThresholds& thresholds);

}  // namespace relit::report
