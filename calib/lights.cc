#include "calib/lights.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "core/error.h"

namespace relit::calib {

namespace {

constexpr int kAzimuthCells = 8;
constexpr int kElevationCells = 3;
constexpr double kDeg = 180.0 / M_PI;

// Lagrange interpolation through (times[i], values[i]) at t.
Eigen::Vector3d Lagrange(const std::vector<double>& times, const std::vector<Eigen::Vector3d>& values, double t) {
  Eigen::Vector3d result = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < times.size(); ++i) {
    double w = 1;
    for (size_t j = 0; j < times.size(); ++j) {
      if (j != i) w *= (t - times[j]) / (times[i] - times[j]);
    }
    result += w * values[i];
  }
  return result;
}

// Cell of a unit direction: azimuth in 45 degree steps, elevation in 30
// degree steps (directions below the horizon count in the lowest band).
int Cell(const Eigen::Vector3d& d) {
  double azimuth = std::atan2(d.y(), d.x());
  if (azimuth < 0) azimuth += 2 * M_PI;
  const int a = std::min(kAzimuthCells - 1, static_cast<int>(azimuth / (2 * M_PI) * kAzimuthCells));
  const double elevation = std::asin(std::clamp(d.z(), -1.0, 1.0));
  const int e = std::clamp(static_cast<int>(elevation / (M_PI / 2) * kElevationCells), 0, kElevationCells - 1);
  return e * kAzimuthCells + a;
}

nlohmann::json Histogram(const std::vector<int>& cells) {
  std::vector<std::vector<int>> counts(kElevationCells, std::vector<int>(kAzimuthCells, 0));
  for (int c : cells) counts[c / kAzimuthCells][c % kAzimuthCells]++;
  return counts;
}

}  // namespace

Eigen::Vector3d FlashPosition(const Rigid3& light_cam_from_world, const Eigen::Vector3d& flash_offset_m) {
  return light_cam_from_world.Inverse() * flash_offset_m;
}

LightsFile InterpolateLights(const std::vector<TimedName>& view_frames,
                             const std::vector<TimedPose>& light_poses,
                             const Eigen::Vector3d& flash_offset_m, double max_gap_s) {
  RELIT_REQUIRE(!light_poses.empty(), "no phone L frame has a pose: cannot place the light for any "
                "phone V frame (is the board visible in phone L's video?)");
  std::vector<double> times;
  std::vector<Eigen::Vector3d> flashes;
  for (size_t i = 0; i < light_poses.size(); ++i) {
    RELIT_CHECK(i == 0 || light_poses[i].time_s > light_poses[i - 1].time_s);
    times.push_back(light_poses[i].time_s);
    flashes.push_back(FlashPosition(light_poses[i].cam_from_world, flash_offset_m));
  }
  LightsFile file;
  file.flash_offset_m = flash_offset_m;
  const int n = static_cast<int>(times.size());
  for (const TimedName& view : view_frames) {
    FrameLight light;
    light.view_frame = view.name;
    light.time_s = view.time_s;
    // First registered phone L frame after the view frame's time.
    const int after = static_cast<int>(std::upper_bound(times.begin(), times.end(), view.time_s) - times.begin());
    const int before = after - 1;
    double gap = std::numeric_limits<double>::infinity();
    if (before >= 0) gap = std::min(gap, view.time_s - times[before]);
    if (after < n) gap = std::min(gap, times[after] - view.time_s);
    light.nearest_light_gap_s = gap;
    if (before < 0 || after >= n) {
      // Outside the registered range: nearest frame, never reliable.
      light.position_m = flashes[before < 0 ? 0 : n - 1];
      light.reliable = false;
    } else {
      // Up to two frames on each side, each within 3 x max_gap_s of its
      // inner neighbour so that a gap is never bridged by a cubic.
      int lo = before, hi = after;
      if (lo - 1 >= 0 && times[lo] - times[lo - 1] <= 3 * max_gap_s) --lo;
      if (hi + 1 < n && times[hi + 1] - times[hi] <= 3 * max_gap_s) ++hi;
      if (hi - lo + 1 == 3) {  // a cubic needs both outer frames; else a quadratic is worse than linear
        lo = before;
        hi = after;
      }
      std::vector<double> t(times.begin() + lo, times.begin() + hi + 1);
      std::vector<Eigen::Vector3d> v(flashes.begin() + lo, flashes.begin() + hi + 1);
      light.position_m = Lagrange(t, v, view.time_s);
      light.reliable = gap <= max_gap_s && times[after] - times[before] <= 2 * max_gap_s + 1e-9;
    }
    file.frames.push_back(light);
  }
  return file;
}

nlohmann::json CoverageSummary(const std::vector<Eigen::Vector3d>& view_centres_m,
                               const std::vector<Eigen::Vector3d>& light_positions_m,
                               const Eigen::Vector3d& centre_m) {
  RELIT_CHECK(view_centres_m.size() == light_positions_m.size());
  std::vector<int> view_cells, light_cells;
  std::set<std::pair<int, int>> pairs;
  std::vector<int> angle_histogram(9, 0);  // 20 degree bins over [0, 180]
  nlohmann::json frames = nlohmann::json::array();
  for (size_t i = 0; i < view_centres_m.size(); ++i) {
    const Eigen::Vector3d v = (view_centres_m[i] - centre_m).normalized();
    const Eigen::Vector3d l = (light_positions_m[i] - centre_m).normalized();
    view_cells.push_back(Cell(v));
    light_cells.push_back(Cell(l));
    pairs.insert({view_cells.back(), light_cells.back()});
    const double angle = std::acos(std::clamp(v.dot(l), -1.0, 1.0)) * kDeg;
    angle_histogram[std::min(8, static_cast<int>(angle / 20.0))]++;
    frames.push_back({{"view_azimuth_deg", std::atan2(v.y(), v.x()) * kDeg},
                      {"view_elevation_deg", std::asin(std::clamp(v.z(), -1.0, 1.0)) * kDeg},
                      {"light_azimuth_deg", std::atan2(l.y(), l.x()) * kDeg},
                      {"light_elevation_deg", std::asin(std::clamp(l.z(), -1.0, 1.0)) * kDeg},
                      {"view_light_angle_deg", angle}});
  }
  const std::set<int> view_set(view_cells.begin(), view_cells.end());
  const std::set<int> light_set(light_cells.begin(), light_cells.end());
  return {{"centre_m", {centre_m.x(), centre_m.y(), centre_m.z()}},
          {"cells", "rows: elevation 0-30, 30-60, 60-90 deg; columns: azimuth in 45 deg steps from +X "
                    "towards +Y"},
          {"view_histogram", Histogram(view_cells)},
          {"light_histogram", Histogram(light_cells)},
          {"view_cells_covered", view_set.size()},
          {"light_cells_covered", light_set.size()},
          {"view_light_cell_pairs", pairs.size()},
          {"cells_total", kAzimuthCells * kElevationCells},
          {"view_light_angle_histogram_20deg", angle_histogram},
          {"frames", frames}};
}

}  // namespace relit::calib
