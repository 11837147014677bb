// The depth-map hull: the region no depth map sees through, on a voxel
// grid (space carving with depth maps, as in Kutulakos & Seitz 2000 and
// the free-space carving of volumetric fusion, Curless & Levoy 1996).
//
// Fused stereo points cover only what the frames saw well: the underside,
// flanks the flash left dark and textureless parts have none, and Poisson
// then bulges or trims there and the cleanup's hole fill guesses. Those
// parts still have a bound: every ray that passes beside the object and
// reaches the table or board behind it says the space it crossed is empty.
// A voxel that at least min_free_views depth maps see through is carved;
// what is left, inside the component holding the fused points, bounds the
// object the way a visual hull does, without any segmentation. Its
// surface, sampled where no fused point is near, is added to the points
// Poisson meshes, so the surface follows the hull where the stereo is
// silent and the points everywhere else.
#pragma once

#include <functional>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/point_surface.h"
#include "reconstruct/reconstruct_options.h"

namespace relit::reconstruct {

struct DepthHullReport {
  Eigen::Vector3i voxels = Eigen::Vector3i::Zero();  // grid size
  double voxel_m = 0;
  int occupied_voxels = 0;      // in the kept component, cavities filled
  int components = 0;           // regions of uncarved voxels
  int surface_points = 0;       // samples of the hull's surface
  int added_points = 0;         // ... farther than the gap from every fused point
  double open_border_fraction = 0;
  double seconds = 0;
  nlohmann::json ToJson() const;
};

// The carved grid itself (for tests and statistics): occupied(i, j, k) for
// voxel centres origin_m + voxel_m * (i + 0.5, j + 0.5, k + 0.5).
struct VoxelHull {
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  double voxel_m = 0;
  Eigen::Vector3i size = Eigen::Vector3i::Zero();
  std::vector<char> occupied;  // x fastest
  int components = 0;          // connected regions of uncarved voxels before keeping one
  // Share of the grid's side and top faces the kept region reaches: near 0
  // when the depth maps carve all around the object; large when they leave
  // it open (a background without depth, too few views).
  double open_border_fraction = 0;
  bool At(int i, int j, int k) const;
  bool Contains(const Eigen::Vector3d& p) const;  // false outside the grid
  Eigen::Vector3i CellOf(const Eigen::Vector3d& p) const;  // the cell holding p (may lie outside the grid)
};

// Carves the grid around `points` (their robust bounding box, widened by
// a margin, from floor_height_m (proxy.min_height_m) up) with `depths`
// (CV_32F, metres along the optical axis, 0 = unknown, the table included)
// of `cameras`.
VoxelHull CarveDepthHull(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& depths,
                         const std::vector<OrientedPoint>& points, const CropRegion& crop,
                         const DepthHullOptions& options, double floor_height_m, double voxel_m,
                         const std::function<void()>& on_slice_done = {});

// Oriented samples of the hull's surface (not its floor)
// that lie farther than gap_m from every point in `points`.
std::vector<OrientedPoint> HullSurfacePoints(const VoxelHull& hull, const std::vector<OrientedPoint>& points,
                                             double gap_m, int* surface_points);

}  // namespace relit::reconstruct
