// The depth-map hull on a scene with a closed-form answer: an upright
// cylinder standing on a table, seen by two rings of cameras whose depth
// maps are ray-traced analytically. Cameras all around a convex object
// that stands on the table carve it to within the tolerance.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "reconstruct/test_workspace.h"
#include "reconstruct/depth_hull.h"

namespace relit::reconstruct {
namespace {

const Eigen::Vector2d kAxis(0.01, -0.02);  // cylinder axis (x, y), metres
constexpr double kRadius = 0.03;
constexpr double kHeight = 0.06;

// Nearest positive ray parameter on the cylinder (side or top cap), or -1.
double HitCylinder(const Eigen::Vector3d& origin, const Eigen::Vector3d& ray) {
  double best = -1;
  auto consider = [&best](double t) {
    if (t > 0 && (best < 0 || t < best)) best = t;
  };
  const Eigen::Vector2d o = origin.head<2>() - kAxis, d = ray.head<2>();
  const double a = d.squaredNorm(), b = o.dot(d), c = o.squaredNorm() - kRadius * kRadius;
  if (a > 0 && b * b - a * c >= 0) {
    for (double sign : {-1.0, 1.0}) {
      const double t = (-b + sign * std::sqrt(b * b - a * c)) / a;
      const double z = origin.z() + t * ray.z();
      if (z >= 0 && z <= kHeight) consider(t);
    }
  }
  if (ray.z() != 0) {
    const double t = (kHeight - origin.z()) / ray.z();
    if ((origin + t * ray).head<2>().operator-(kAxis).norm() <= kRadius) consider(t);
  }
  return best;
}

// Depth along the optical axis of the cylinder, else of the table, else
// unknown. Without the table the cylinder's top half is black too.
cv::Mat RenderDepth(const Camera& camera, bool table) {
  auto hit = [table](const Eigen::Vector3d& origin, const Eigen::Vector3d& ray) {
    const double t = HitCylinder(origin, ray);
    return !table && t > 0 && origin.z() + t * ray.z() > kHeight / 2 ? -1.0 : t;
  };
  return testing::RenderAnalyticDepth(camera, hit, table);
}

struct Views {
  std::vector<Camera> cameras;
  std::vector<cv::Mat> depths;
};

Views RingOfViews(bool table = true) {
  Views views;
  const Eigen::Vector3d target(kAxis.x(), kAxis.y(), kHeight / 2);
  views.cameras = testing::TwoRingsOfCameras(target, 20.0, 45.0);
  for (const Camera& camera : views.cameras) views.depths.push_back(RenderDepth(camera, table));
  return views;
}

std::vector<OrientedPoint> SidePoints(double z_low, double z_high, double min_normal_x);

// What the fused stereo points would be: the top cap and the side above
// half the height (the lower half "unseen"), 1 mm apart.
std::vector<OrientedPoint> UpperPoints() {
  std::vector<OrientedPoint> points;
  for (double r = 0; r < kRadius; r += 0.001) {
    const int steps = std::max(1, static_cast<int>(2 * M_PI * r / 0.001));
    for (int s = 0; s < steps; ++s) {
      const double a = 2 * M_PI * s / steps;
      points.push_back({Eigen::Vector3d(kAxis.x() + r * std::cos(a), kAxis.y() + r * std::sin(a), kHeight),
                        Eigen::Vector3d::UnitZ()});
    }
  }
  const std::vector<OrientedPoint> side = SidePoints(kHeight / 2, kHeight, -1.0);
  points.insert(points.end(), side.begin(), side.end());
  return points;
}

// Signed distance to the cylinder (negative inside), metres.
double CylinderDistance(const Eigen::Vector3d& p) {
  const double radial = (p.head<2>() - kAxis).norm() - kRadius;
  const double vertical = std::max(p.z() - kHeight, -p.z());
  if (radial > 0 && vertical > 0) return std::hypot(radial, vertical);
  return std::max(radial, vertical);
}

// Side points from z_low to z_high where the outward normal's x is at
// least min_normal_x, 1 mm apart.
std::vector<OrientedPoint> SidePoints(double z_low, double z_high, double min_normal_x) {
  std::vector<OrientedPoint> points;
  for (double z = z_low; z < z_high; z += 0.001) {
    for (int s = 0; s < 188; ++s) {
      const double a = 2 * M_PI * s / 188;
      const Eigen::Vector3d n(std::cos(a), std::sin(a), 0);
      if (n.x() >= min_normal_x) points.push_back({Eigen::Vector3d(kAxis.x(), kAxis.y(), z) + kRadius * n, n});
    }
  }
  return points;
}

// Without the contact band: the cylinder's lower half has no fused points
// here, so the band would carve its foot (tested on its own below).
DepthHullOptions HullOptions() {
  DepthHullOptions options;
  options.contact_height_m = 0;
  return options;
}
constexpr double kFloor = 0.005;  // proxy.min_height_m

CropRegion Crop() {
  CropRegion crop;
  crop.centre_xy = kAxis;
  crop.radius_m = 0.12;
  return crop;
}

TEST(DepthHull, CarvesTheSpaceAroundAnUprightCylinderAndKeepsItsInside) {
  const Views views = RingOfViews();
  const DepthHullOptions options = HullOptions();
  constexpr double kVoxel = 0.0015;
  const VoxelHull hull = CarveDepthHull(views.cameras, views.depths, UpperPoints(), Crop(), options, kFloor, kVoxel);
  ASSERT_GT(hull.size.prod(), 0);
  int inside = 0, inside_carved = 0, outside_far = 0, outside_far_kept = 0;
  for (int k = 0; k < hull.size.z(); ++k) {
    for (int j = 0; j < hull.size.y(); ++j) {
      for (int i = 0; i < hull.size.x(); ++i) {
        const Eigen::Vector3d centre = hull.origin_m + kVoxel * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        const double distance = CylinderDistance(centre);
        if (distance < -kVoxel) {
          ++inside;
          if (!hull.At(i, j, k)) ++inside_carved;
        } else if (distance > 0.008) {
          ++outside_far;
          if (hull.At(i, j, k)) ++outside_far_kept;
        }
      }
    }
  }
  EXPECT_GT(inside, 10000);
  EXPECT_EQ(inside_carved, 0) << "the hull must never cut into the object";
  // Two rings of 12 views leave the hull a 24-sided prism at most; beyond
  // 8 mm (the 1 % tolerance at 0.4 m plus a voxel) nothing is left.
  EXPECT_LT(outside_far_kept, outside_far / 1000) << outside_far_kept << " of " << outside_far;
}

TEST(DepthHull, SurfacePointsFillOnlyWhereNoFusedPointIs) {
  const Views views = RingOfViews();
  const DepthHullOptions options = HullOptions();
  const std::vector<OrientedPoint> fused = UpperPoints();
  const VoxelHull hull = CarveDepthHull(views.cameras, views.depths, fused, Crop(), options, kFloor, 0.0015);
  int surface = 0;
  const std::vector<OrientedPoint> added = HullSurfacePoints(hull, fused, 0.003, &surface);
  ASSERT_GT(added.size(), 500u);
  EXPECT_GT(surface, static_cast<int>(added.size()));
  double sum = 0;
  int above = 0, far = 0, inward = 0;
  for (const OrientedPoint& p : added) {
    // Only the lower half, which the fused points do not cover.
    if (p.position_m.z() > kHeight / 2 + 0.001) ++above;
    const double distance = CylinderDistance(p.position_m);
    sum += std::abs(distance);
    if (std::abs(distance) > 0.008) ++far;
    // Outward normals (the side's, horizontal).
    const Eigen::Vector2d radial = (p.position_m.head<2>() - kAxis).normalized();
    if (p.normal.head<2>().dot(radial) < 0.8) ++inward;
  }
  EXPECT_EQ(above, 0);
  EXPECT_EQ(far, 0);
  EXPECT_EQ(inward, 0);
  EXPECT_LT(sum / added.size(), 0.004);
}

TEST(DepthHull, OneWrongDepthMapDoesNotCarveTheObject) {
  Views views = RingOfViews();
  // A stereo failure that sees far through the middle of the object.
  views.depths[0].rowRange(110, 130).setTo(1.0f);
  DepthHullOptions options = HullOptions();
  const VoxelHull hull = CarveDepthHull(views.cameras, views.depths, UpperPoints(), Crop(), options, kFloor, 0.002);
  EXPECT_TRUE(hull.Contains(Eigen::Vector3d(kAxis.x(), kAxis.y(), kHeight / 2)));
  EXPECT_TRUE(hull.Contains(Eigen::Vector3d(kAxis.x() + 0.02, kAxis.y(), 0.01)));
  // With one view enough to carve, the same failure cuts through it.
  options.min_free_views = 1;
  const VoxelHull carved = CarveDepthHull(views.cameras, views.depths, UpperPoints(), Crop(), options, kFloor, 0.002);
  int lost = 0;
  for (double z = 0.01; z < kHeight; z += 0.005) {
    lost += carved.Contains(Eigen::Vector3d(kAxis.x(), kAxis.y(), z)) ? 0 : 1;
  }
  EXPECT_GT(lost, 0);
}

TEST(DepthHull, TheBandUnderTheObjectKeepsTheContactRegionAndWhatTheObjectEncloses) {
  const Views views = RingOfViews();
  DepthHullOptions options = HullOptions();
  options.contact_height_m = 0.01;
  options.contact_radius_m = 0.005;
  const Eigen::Vector3d centre_low(kAxis.x(), kAxis.y(), 0.01);
  const Eigen::Vector3d minus_x_low(kAxis.x() - 0.025, kAxis.y(), 0.01), plus_x_low(kAxis.x() + 0.025, kAxis.y(), 0.01);
  // Points down to the table all around: the band inside is enclosed.
  std::vector<OrientedPoint> points = UpperPoints();
  const std::vector<OrientedPoint> all_round = SidePoints(kFloor, kHeight / 2, -1.0);
  points.insert(points.end(), all_round.begin(), all_round.end());
  const VoxelHull enclosed = CarveDepthHull(views.cameras, views.depths, points, Crop(), options, kFloor, 0.0015);
  EXPECT_TRUE(enclosed.Contains(centre_low));
  EXPECT_TRUE(enclosed.Contains(minus_x_low));
  EXPECT_TRUE(enclosed.Contains(plus_x_low));
  // Only the +x half reaches the table: the band under the -x half opens.
  points = UpperPoints();
  const std::vector<OrientedPoint> half = SidePoints(kFloor, kHeight / 2, 0.0);
  points.insert(points.end(), half.begin(), half.end());
  const VoxelHull open = CarveDepthHull(views.cameras, views.depths, points, Crop(), options, kFloor, 0.0015);
  EXPECT_TRUE(open.Contains(plus_x_low));
  EXPECT_FALSE(open.Contains(minus_x_low));
  EXPECT_FALSE(open.Contains(centre_low));
  EXPECT_TRUE(open.Contains(Eigen::Vector3d(kAxis.x() - 0.025, kAxis.y(), 0.02)));  // above the band
}

TEST(DepthHull, WithoutDepthBehindTheObjectTheHullStaysOpen) {
  const DepthHullOptions options = HullOptions();
  const VoxelHull closed = CarveDepthHull(RingOfViews().cameras, RingOfViews().depths, UpperPoints(), Crop(),
                                          options, kFloor, 0.002);
  EXPECT_LT(closed.open_border_fraction, 0.001);
  // Only the lower half of the object has depth (the table and the top are
  // black, say): nothing carves the space above it, so the hull reaches the
  // grid's top and the stage does not use it.
  const Views no_table = RingOfViews(false);
  const VoxelHull open = CarveDepthHull(no_table.cameras, no_table.depths, UpperPoints(), Crop(), options, kFloor, 0.002);
  EXPECT_GT(open.open_border_fraction, 0.5);
  EXPECT_GT(open.open_border_fraction, options.max_open_border);
}

TEST(DepthHull, BadInputIsAnError) {
  const Views views = RingOfViews();
  const DepthHullOptions options = HullOptions();
  std::vector<cv::Mat> too_few(views.depths.begin(), views.depths.begin() + 3);
  EXPECT_THROW(CarveDepthHull(views.cameras, too_few, UpperPoints(), Crop(), options, kFloor, 0.002), Error);
  EXPECT_THROW(CarveDepthHull(views.cameras, views.depths, {}, Crop(), options, kFloor, 0.002), Error);
  EXPECT_THROW(CarveDepthHull(views.cameras, views.depths, UpperPoints(), Crop(), options, kFloor, 0.0), Error);
}

}  // namespace
}  // namespace relit::reconstruct
