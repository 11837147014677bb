// Phone L's flash position for every phone V frame: the flash positions of
// the registered phone L frames (camera pose plus the flash-to-lens offset)
// interpolated in time, and a summary of how view and light directions
// cover the upper hemisphere.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/camera.h"
#include "core/workspace.h"

namespace relit::calib {

struct TimedPose {
  double time_s = 0;          // common clock
  Rigid3 cam_from_world;
};

struct TimedName {
  std::string name;
  double time_s = 0;
};

// The flash in world coordinates for a phone L pose.
Eigen::Vector3d FlashPosition(const Rigid3& light_cam_from_world, const Eigen::Vector3d& flash_offset_m);

// For each view frame: the flash position at its time, interpolated with a
// cubic through the two registered phone L frames on each side (Lagrange,
// non-uniform times; linear with one on each side). Frames outside the
// registered phone L time range get the nearest one and are unreliable, as
// are frames whose nearest registered phone L frame is more than max_gap_s
// away. `light_poses` must be sorted by time.
LightsFile InterpolateLights(const std::vector<TimedName>& view_frames,
                             const std::vector<TimedPose>& light_poses,
                             const Eigen::Vector3d& flash_offset_m, double max_gap_s);

// View x light coverage of the upper hemisphere around `centre_m`: per frame
// azimuth/elevation of the view and light directions, histograms over 8
// azimuth x 3 elevation cells, the occupied (view cell, light cell) pairs
// and a histogram of the view-light angle.
nlohmann::json CoverageSummary(const std::vector<Eigen::Vector3d>& view_centres_m,
                               const std::vector<Eigen::Vector3d>& light_positions_m,
                               const Eigen::Vector3d& centre_m);

}  // namespace relit::calib
