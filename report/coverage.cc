#include "report/coverage.h"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/Geometry>

#include "core/error.h"
#include "core/median.h"

namespace relit::report {

namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

std::string Fixed(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", value);
  return text;
}

}  // namespace

RELIT_OPTION_FIELDS(CoverageThresholds,
    .Add("min_view_spread_deg", &S::min_view_spread_deg, 0.0, 90.0, "warn below this spread of camera directions")
    .Add("min_light_spread_deg", &S::min_light_spread_deg, 0.0, 90.0, "... of light directions")
    .Add("min_relative_light_spread_deg", &S::min_relative_light_spread_deg, 0.0, 90.0,
         "... of the light seen from the camera")
    .Add("min_view_light_angle_deg", &S::min_view_light_angle_deg, 0.0, 180.0,
         "warn below this median angle between camera and light"))

// The JSON keys are the members' names.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(CoverageStats, frames, view_spread_deg, light_spread_deg,
                                   relative_light_spread_deg, median_view_light_angle_deg, view_cells, light_cells,
                                   view_light_cell_pairs, warnings)

nlohmann::json CoverageStats::ToJson() const { return *this; }

double AngularSpreadDeg(const std::vector<Eigen::Vector3d>& directions) {
  if (directions.empty()) return 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& d : directions) {
    RELIT_REQUIRE(d.norm() > 0, "coverage: zero direction (camera or light at the object centre)");
    sum += d.normalized();
  }
  const double resultant = sum.norm() / directions.size();
  return std::acos(std::clamp(resultant, 0.0, 1.0)) * kDeg;
}

Eigen::Vector3d LightInViewFrame(const Eigen::Vector3d& view, const Eigen::Vector3d& light) {
  const Eigen::Vector3d z = view.normalized();
  Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z);
  if (x.norm() < 1e-9) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  const Eigen::Vector3d l = light.normalized();
  return {x.dot(l), y.dot(l), z.dot(l)};
}

int HemisphereCell(const Eigen::Vector3d& direction) {
  const Eigen::Vector3d d = direction.normalized();
  const double elevation = std::asin(std::clamp(d.z(), -1.0, 1.0)) * kDeg;
  double azimuth = std::atan2(d.y(), d.x()) * kDeg;
  if (azimuth < 0) azimuth += 360;
  const int band = std::clamp(static_cast<int>(elevation / 30.0), 0, 2);
  const int sector = std::clamp(static_cast<int>(azimuth / 45.0), 0, 7);
  return band * 8 + sector;
}

CoverageStats ComputeCoverage(const std::vector<Eigen::Vector3d>& view_directions,
                              const std::vector<Eigen::Vector3d>& light_directions,
                              const CoverageThresholds& thresholds) {
  RELIT_REQUIRE(view_directions.size() == light_directions.size(),
                "coverage: ", view_directions.size(), " view directions but ", light_directions.size(),
                " light directions");
  CoverageStats stats;
  stats.frames = static_cast<int>(view_directions.size());
  if (stats.frames == 0) {
    stats.warnings.push_back("no frame has both a camera pose and a light position");
    return stats;
  }
  stats.view_spread_deg = AngularSpreadDeg(view_directions);
  stats.light_spread_deg = AngularSpreadDeg(light_directions);
  std::vector<Eigen::Vector3d> relative;
  std::vector<double> angles;
  std::set<int> view_cells, light_cells;
  std::set<std::pair<int, int>> pairs;
  for (size_t i = 0; i < view_directions.size(); ++i) {
    const Eigen::Vector3d& v = view_directions[i];
    const Eigen::Vector3d& l = light_directions[i];
    RELIT_REQUIRE(v.norm() > 0 && l.norm() > 0, "coverage: camera or light at the object centre (frame ", i, ")");
    relative.push_back(LightInViewFrame(v, l));
    angles.push_back(std::acos(std::clamp(v.normalized().dot(l.normalized()), -1.0, 1.0)) * kDeg);
    const int vc = HemisphereCell(v), lc = HemisphereCell(l);
    view_cells.insert(vc);
    light_cells.insert(lc);
    pairs.insert({vc, lc});
  }
  stats.relative_light_spread_deg = AngularSpreadDeg(relative);
  stats.median_view_light_angle_deg = Median(std::move(angles));
  stats.view_cells = static_cast<int>(view_cells.size());
  stats.light_cells = static_cast<int>(light_cells.size());
  stats.view_light_cell_pairs = static_cast<int>(pairs.size());

  if (stats.view_spread_deg < thresholds.min_view_spread_deg) {
    stats.warnings.push_back("camera directions cover a narrow cone (spread " + Fixed(stats.view_spread_deg) +
                             "° < " + Fixed(thresholds.min_view_spread_deg) +
                             "°): walk further around the object and vary the height");
  }
  if (stats.light_spread_deg < thresholds.min_light_spread_deg) {
    stats.warnings.push_back("light directions cover a narrow cone (spread " + Fixed(stats.light_spread_deg) +
                             "° < " + Fixed(thresholds.min_light_spread_deg) +
                             "°): move the flash phone over more of the hemisphere");
  }
  if (stats.median_view_light_angle_deg < thresholds.min_view_light_angle_deg) {
    stats.warnings.push_back("the light is almost always next to the camera (median view-light angle " +
                             Fixed(stats.median_view_light_angle_deg) + "° < " +
                             Fixed(thresholds.min_view_light_angle_deg) +
                             "°): film with the flash on the second phone, not on the camera phone");
  }
  if (stats.relative_light_spread_deg < thresholds.min_relative_light_spread_deg) {
    stats.warnings.push_back("view and light directions are strongly correlated: seen from the camera the light "
                             "barely moves (relative spread " + Fixed(stats.relative_light_spread_deg) + "° < " +
                             Fixed(thresholds.min_relative_light_spread_deg) +
                             "°); move the two phones independently (different speeds, heights, directions)");
  }
  return stats;
}

}  // namespace relit::report
