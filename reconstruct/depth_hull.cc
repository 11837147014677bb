#include "reconstruct/depth_hull.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>

#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "reconstruct/depth_fusion.h"

namespace relit::reconstruct {

nlohmann::json DepthHullReport::ToJson() const {
  return {{"voxels", {voxels.x(), voxels.y(), voxels.z()}},
          {"voxel_m", voxel_m},
          {"occupied_voxels", occupied_voxels},
          {"components", components},
          {"surface_points", surface_points},
          {"added_points", added_points},
          {"open_border_fraction", open_border_fraction},
          {"seconds", seconds}};
}

namespace {

struct Grid {
  Eigen::Vector3i size;
  size_t Index(int i, int j, int k) const { return (static_cast<size_t>(k) * size.y() + j) * size.x() + i; }
  bool Inside(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < size.x() && j < size.y() && k < size.z();
  }
  // On the grid's sides or top; not the floor, which the table closes.
  bool OnOpenBorder(int i, int j, int k) const {
    return i == 0 || j == 0 || i == size.x() - 1 || j == size.y() - 1 || k == size.z() - 1;
  }
};

}  // namespace

bool VoxelHull::At(int i, int j, int k) const {
  const Grid grid{size};
  return grid.Inside(i, j, k) && occupied[grid.Index(i, j, k)] != 0;
}

Eigen::Vector3i VoxelHull::CellOf(const Eigen::Vector3d& p) const {
  return ((p - origin_m) / voxel_m).array().floor().cast<int>();
}

bool VoxelHull::Contains(const Eigen::Vector3d& p) const {
  const Eigen::Vector3i c = CellOf(p);
  return At(c.x(), c.y(), c.z());
}

namespace {

double Percentile(std::vector<double> values, double q) {
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}


constexpr std::array<std::array<int, 3>, 6> kNeighbours = {
    {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}};

// Labels 6-connected regions where mask == value; returns the label per
// voxel (-1 elsewhere) and the region count.
std::vector<int> Label(const Grid& grid, const std::vector<char>& mask, char value, int* count) {
  std::vector<int> label(mask.size(), -1);
  *count = 0;
  std::deque<Eigen::Vector3i> queue;
  for (int k = 0; k < grid.size.z(); ++k) {
    for (int j = 0; j < grid.size.y(); ++j) {
      for (int i = 0; i < grid.size.x(); ++i) {
        if (mask[grid.Index(i, j, k)] != value || label[grid.Index(i, j, k)] >= 0) continue;
        label[grid.Index(i, j, k)] = *count;
        queue.push_back({i, j, k});
        while (!queue.empty()) {
          const Eigen::Vector3i v = queue.front();
          queue.pop_front();
          for (const auto& d : kNeighbours) {
            const int a = v.x() + d[0], b = v.y() + d[1], c = v.z() + d[2];
            if (!grid.Inside(a, b, c) || mask[grid.Index(a, b, c)] != value || label[grid.Index(a, b, c)] >= 0) {
              continue;
            }
            label[grid.Index(a, b, c)] = *count;
            queue.push_back({a, b, c});
          }
        }
        ++*count;
      }
    }
  }
  return label;
}

}  // namespace

VoxelHull CarveDepthHull(const std::vector<Camera>& cameras, const std::vector<cv::Mat>& depths,
                         const std::vector<OrientedPoint>& points, const CropRegion& crop,
                         const DepthHullOptions& options, double floor_height_m, double voxel_m,
                         const std::function<void()>& on_slice_done) {
  RELIT_REQUIRE(cameras.size() == depths.size(), "depth hull: ", cameras.size(), " cameras but ", depths.size(),
                " depth maps");
  RELIT_REQUIRE(points.size() >= 10, "depth hull: needs the fused points to place its grid, got ", points.size());
  RELIT_REQUIRE(voxel_m > 0, "depth hull: the voxel size must be positive, got ", voxel_m);

  // The grid: the fused points' robust bounds, widened so that the parts
  // the stereo missed fit, from the fusion's floor up.
  std::array<std::vector<double>, 3> coords;
  for (const OrientedPoint& p : points) {
    for (int a = 0; a < 3; ++a) coords[a].push_back(p.position_m[a]);
  }
  Eigen::Vector3d low, high;
  for (int a = 0; a < 3; ++a) {
    low[a] = Percentile(coords[a], 0.005);
    high[a] = Percentile(coords[a], 0.995);
  }
  const double margin = std::max(0.02, options.margin_fraction * (high - low).maxCoeff());
  low -= Eigen::Vector3d::Constant(margin);
  high += Eigen::Vector3d::Constant(margin);
  low.z() = floor_height_m;
  for (int a = 0; a < 2; ++a) {
    low[a] = std::max(low[a], crop.centre_xy[a] - crop.radius_m);
    high[a] = std::min(high[a], crop.centre_xy[a] + crop.radius_m);
  }
  RELIT_REQUIRE((high - low).minCoeff() > 0, "depth hull: the fused points leave no room above the board");
  VoxelHull hull;
  hull.voxel_m = voxel_m;
  // Coarser voxels rather than an unbounded grid (about 16 M voxels at most).
  while (((high - low) / hull.voxel_m).prod() > 16e6) hull.voxel_m *= 1.25;
  hull.origin_m = low;
  hull.size = ((high - low) / hull.voxel_m).array().ceil().cast<int>().max(1);
  const Grid grid{hull.size};
  const size_t count = static_cast<size_t>(hull.size.prod());

  // A ray carves only when even the nearest surface around its pixel lies
  // behind the voxel.
  std::vector<cv::Mat> nearest(depths.size());
  tbb::parallel_for(size_t(0), depths.size(), [&](size_t v) { nearest[v] = NearestDepth3x3(depths[v]); });
  // The whole voxel, not only its centre, must lie in front of the seen surface.
  const double half_diagonal = 0.87 * hull.voxel_m;
  std::vector<char> carved(count, 0);
  tbb::parallel_for(0, hull.size.z(), [&](int k) {
    for (int j = 0; j < hull.size.y(); ++j) {
      for (int i = 0; i < hull.size.x(); ++i) {
        const Eigen::Vector3d centre = hull.origin_m + hull.voxel_m * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        int free_views = 0;
        for (size_t v = 0; v < cameras.size() && free_views < options.min_free_views; ++v) {
          const Eigen::Vector3d in_cam = cameras[v].cam_from_world() * centre;
          cv::Point pixel;
          if (!NearestPixel(cameras[v], in_cam, nearest[v].size(), &pixel)) continue;
          const float seen = nearest[v].at<float>(pixel);
          if (seen > 0 && seen > in_cam.z() * (1 + options.free_tolerance) + half_diagonal) ++free_views;
        }
        carved[grid.Index(i, j, k)] = free_views >= options.min_free_views ? 1 : 0;
      }
    }
    if (on_slice_done) on_slice_done();
  });

  // Under the object, what no view saw is assumed empty down to the table
  // except where fused points come down to it (the feet): the bottom band
  // outside that contact region is carved. A band the object encloses (a
  // box's underside) stays a cavity and is filled again below.
  const int band = static_cast<int>(std::ceil(options.contact_height_m / hull.voxel_m));
  if (band > 0) {
    cv::Mat contact(hull.size.y(), hull.size.x(), CV_8U, cv::Scalar(0));
    for (const OrientedPoint& p : points) {
      if (p.position_m.z() >= floor_height_m + options.contact_height_m) continue;
      const Eigen::Vector3i c = hull.CellOf(p.position_m);
      if (c.x() >= 0 && c.y() >= 0 && c.x() < hull.size.x() && c.y() < hull.size.y()) contact.at<uchar>(c.y(), c.x()) = 1;
    }
    const int radius = static_cast<int>(std::ceil(options.contact_radius_m / hull.voxel_m));
    if (radius > 0) {
      cv::dilate(contact, contact, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * radius + 1, 2 * radius + 1}));
    }
    for (int k = 0; k < std::min(band, hull.size.z()); ++k) {
      for (int j = 0; j < hull.size.y(); ++j) {
        for (int i = 0; i < hull.size.x(); ++i) {
          if (!contact.at<uchar>(j, i)) carved[grid.Index(i, j, k)] = 1;
        }
      }
    }
  }

  // Keep the uncarved region holding most fused points.
  int regions = 0;
  const std::vector<int> label = Label(grid, carved, 0, &regions);
  hull.components = regions;
  RELIT_REQUIRE(regions > 0, "depth hull: the depth maps carve the whole region around the fused points; "
                "are the depth maps and cameras consistent?");
  std::vector<int> votes(regions, 0);
  for (const OrientedPoint& p : points) {
    const Eigen::Vector3i c = hull.CellOf(p.position_m);
    if (grid.Inside(c.x(), c.y(), c.z()) && label[grid.Index(c.x(), c.y(), c.z())] >= 0) {
      ++votes[label[grid.Index(c.x(), c.y(), c.z())]];
    }
  }
  const int keep = static_cast<int>(std::max_element(votes.begin(), votes.end()) - votes.begin());
  // Cavities: carved pockets the outside cannot reach are inside the object.
  std::vector<char> outside_mask(count, 0);
  for (size_t v = 0; v < count; ++v) outside_mask[v] = label[v] == keep ? 0 : 1;
  int outside_regions = 0;
  const std::vector<int> outside = Label(grid, outside_mask, 1, &outside_regions);
  std::vector<char> touches_border(outside_regions, 0);
  for (int k = 0; k < hull.size.z(); ++k) {
    for (int j = 0; j < hull.size.y(); ++j) {
      for (int i = 0; i < hull.size.x(); ++i) {
        if (grid.OnOpenBorder(i, j, k) && outside[grid.Index(i, j, k)] >= 0) {
          touches_border[outside[grid.Index(i, j, k)]] = 1;
        }
      }
    }
  }
  hull.occupied.assign(count, 0);
  for (size_t v = 0; v < count; ++v) {
    hull.occupied[v] = label[v] == keep || (outside[v] >= 0 && !touches_border[outside[v]]) ? 1 : 0;
  }
  int border_voxels = 0, open_voxels = 0;
  for (int k = 0; k < hull.size.z(); ++k) {
    for (int j = 0; j < hull.size.y(); ++j) {
      for (int i = 0; i < hull.size.x(); ++i) {
        if (grid.OnOpenBorder(i, j, k)) {
          ++border_voxels;
          open_voxels += hull.occupied[grid.Index(i, j, k)];
        }
      }
    }
  }
  hull.open_border_fraction = border_voxels ? static_cast<double>(open_voxels) / border_voxels : 0.0;
  return hull;
}

std::vector<OrientedPoint> HullSurfacePoints(const VoxelHull& hull, const std::vector<OrientedPoint>& points,
                                             double gap_m, int* surface_points) {
  const Grid grid{hull.size};
  // Occupancy smoothed by a binomial 1-4-6-4-1 kernel along each axis: the
  // surface samples sit where it crosses 1/2, normals along its gradient,
  // instead of on the voxels' staircase.
  std::vector<float> field(hull.occupied.begin(), hull.occupied.end());
  constexpr std::array<float, 5> kKernel = {1 / 16.f, 4 / 16.f, 6 / 16.f, 4 / 16.f, 1 / 16.f};
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<float> blurred(field.size(), 0.f);
    tbb::parallel_for(0, hull.size.z(), [&](int k) {
      for (int j = 0; j < hull.size.y(); ++j) {
        for (int i = 0; i < hull.size.x(); ++i) {
          float sum = 0;
          for (int t = -2; t <= 2; ++t) {
            Eigen::Vector3i q(i, j, k);
            // Clamped: below the floor the object continues (it stands
            // on the table), so the floor is not a crossing.
            q[axis] = std::clamp(q[axis] + t, 0, hull.size[axis] - 1);
            sum += kKernel[t + 2] * field[grid.Index(q.x(), q.y(), q.z())];
          }
          blurred[grid.Index(i, j, k)] = sum;
        }
      }
    });
    field.swap(blurred);
  }
  auto value = [&](int i, int j, int k) {
    i = std::clamp(i, 0, hull.size.x() - 1);
    j = std::clamp(j, 0, hull.size.y() - 1);
    k = std::clamp(k, 0, hull.size.z() - 1);
    return field[grid.Index(i, j, k)];
  };
  std::vector<OrientedPoint> samples;
  for (int k = 0; k < hull.size.z(); ++k) {
    for (int j = 0; j < hull.size.y(); ++j) {
      for (int i = 0; i < hull.size.x(); ++i) {
        const float f0 = value(i, j, k);
        // One sample per grid edge where the smoothed field crosses 1/2
        // (edges to +x, +y, +z; the floor stays open).
        for (int axis = 0; axis < 3; ++axis) {
          Eigen::Vector3i n(i, j, k);
          n[axis] += 1;
          if (!grid.Inside(n.x(), n.y(), n.z())) continue;
          const float f1 = value(n.x(), n.y(), n.z());
          if ((f0 >= 0.5f) == (f1 >= 0.5f)) continue;
          const double t = (0.5 - f0) / (f1 - f0);
          Eigen::Vector3d position =
              hull.origin_m + hull.voxel_m * (Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5) + t * (n - Eigen::Vector3i(i, j, k)).cast<double>());
          auto gradient = [&](int a, int b, int c) {
            return Eigen::Vector3d(value(a + 1, b, c) - value(a - 1, b, c), value(a, b + 1, c) - value(a, b - 1, c),
                                   value(a, b, c + 1) - value(a, b, c - 1));
          };
          const Eigen::Vector3d g = (1 - t) * gradient(i, j, k) + t * gradient(n.x(), n.y(), n.z());
          if (g.norm() <= 0) continue;
          samples.push_back({position, -g.normalized()});
        }
      }
    }
  }
  *surface_points = static_cast<int>(samples.size());
  // Only where no fused point is within gap_m.
  std::vector<Eigen::Vector3d> sample_positions, point_positions;
  for (const OrientedPoint& s : samples) sample_positions.push_back(s.position_m);
  for (const OrientedPoint& p : points) point_positions.push_back(p.position_m);
  if (point_positions.empty()) return samples;
  const std::vector<double> nearest = DistancesToPoints(sample_positions, point_positions);
  std::vector<OrientedPoint> added;
  for (size_t s = 0; s < samples.size(); ++s) {
    if (nearest[s] >= gap_m) added.push_back(samples[s]);
  }
  return added;
}

}  // namespace relit::reconstruct
