// Refinement against depth maps on a scene with a closed-form answer: a
// sphere above a table, seen by a ring of cameras whose depth maps are
// ray-traced analytically.
#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "reconstruct/test_workspace.h"
#include "core/render/mesh.h"
#include "reconstruct/visibility_refine.h"

namespace relit::reconstruct {
namespace {

const Eigen::Vector3d kCentre(0.01, -0.02, 0.05);
constexpr double kRadius = 0.03;

// Depth (along the optical axis) of the sphere, else of the table, else
// unknown; Gaussian noise of `noise_m`.
cv::Mat RenderDepth(const Camera& camera, double noise_m, std::mt19937* rng) {
  auto hit = [](const Eigen::Vector3d& origin, const Eigen::Vector3d& ray) {
    return testing::RaySphere(origin, ray, kCentre, kRadius);
  };
  cv::Mat depth = testing::RenderAnalyticDepth(camera, hit, /*table=*/true);
  if (noise_m > 0) {
    std::normal_distribution<double> noise(0.0, noise_m);
    for (float& z : cv::Mat_<float>(depth)) {
      if (z > 0) z = static_cast<float>(z + noise(*rng));
    }
  }
  return depth;
}

DepthEvidence RingOfViews(double noise_m) {
  DepthEvidence evidence;
  std::mt19937 rng(7);
  evidence.cameras = testing::TwoRingsOfCameras(kCentre, 15.0, 45.0);
  for (const Camera& camera : evidence.cameras) {
    evidence.names.push_back("view_" + std::to_string(evidence.names.size()));
    evidence.depths.push_back(RenderDepth(camera, noise_m, &rng));
  }
  return evidence;
}

// The distance of the vertices from the true sphere: mean and max (metres);
// with `upper_only`, of those above its centre (the cameras at 15 and 45
// degrees see the lower half at grazing angles or not at all).
std::pair<double, double> SphereError(const render::TriangleMesh& mesh, bool upper_only = false) {
  double sum = 0, max = 0;
  int count = 0;
  for (const Eigen::Vector3f& p : mesh.positions) {
    if (upper_only && p.z() < kCentre.z()) continue;
    const double e = std::abs((p.cast<double>() - kCentre).norm() - kRadius);
    sum += e;
    max = std::max(max, e);
    ++count;
  }
  return {sum / count, max};
}

render::TriangleMesh Sphere(double radius) { return render::MakeSphere(kCentre.cast<float>(), radius, 48, 24); }

TEST(VisibilityRefineTest, AnInflatedProxyIsCarvedToTheSeenSurface) {
  const DepthEvidence evidence = RingOfViews(0.0);
  const render::TriangleMesh proxy = Sphere(kRadius + 0.01);
  ASSERT_NEAR(SphereError(proxy).first, 0.01, 1e-4);
  // A tolerance below the 10-mm gap (3 % of the views' distance): carving
  // itself moves the vertices in.
  RefineOptions carving;
  carving.free_space_tolerance = 0.01;
  RefineReport report;
  const render::TriangleMesh refined = RefineWithDepthMaps(proxy, evidence, carving, 0.0, &report);
  const auto [mean, max] = SphereError(refined);
  EXPECT_LT(mean, 0.0025) << "max " << max;  // from 10 mm
  EXPECT_LT(SphereError(refined, true).first, 0.001);
  EXPECT_GT(report.carved_vertices_first, 0.5 * report.vertices);
  EXPECT_EQ(refined.triangles, proxy.triangles);
}

TEST(VisibilityRefineTest, AnInflatedProxyIsPulledInWithTheDefaultTolerance) {
  // The default tolerance (10 %) lies beyond this gap: no view sees through,
  // and the support pull alone brings the sphere in.
  const DepthEvidence evidence = RingOfViews(0.0);
  const render::TriangleMesh proxy = Sphere(kRadius + 0.01);
  RefineReport report;
  const render::TriangleMesh refined = RefineWithDepthMaps(proxy, evidence, RefineOptions{}, 0.0, &report);
  const auto [mean, max] = SphereError(refined);
  EXPECT_LT(mean, 0.003) << "max " << max;  // from 10 mm
  EXPECT_LT(SphereError(refined, true).first, 0.0015);
}

TEST(VisibilityRefineTest, AShrunkenProxyIsPulledOutToTheSeenSurface) {
  const DepthEvidence evidence = RingOfViews(0.0);
  const render::TriangleMesh proxy = Sphere(kRadius - 0.0025);
  RefineReport report;
  const render::TriangleMesh refined = RefineWithDepthMaps(proxy, evidence, RefineOptions{}, 0.0, &report);
  EXPECT_LT(SphereError(refined).first, 0.001);
  EXPECT_EQ(report.carved_vertices_first, 0);
}

TEST(VisibilityRefineTest, NoisyDepthMapsAverageOut) {
  // 2 mm of noise per pixel (several pixels of disparity at these baselines):
  // the vertices sit much closer than that because every view votes.
  const DepthEvidence evidence = RingOfViews(0.002);
  const render::TriangleMesh proxy = Sphere(kRadius + 0.003);
  RefineReport report;
  const render::TriangleMesh refined = RefineWithDepthMaps(proxy, evidence, RefineOptions{}, 0.0, &report);
  EXPECT_LT(SphereError(refined).first, 0.001);
}

TEST(VisibilityRefineTest, WithoutEvidenceTheProxyStays) {
  DepthEvidence evidence = RingOfViews(0.0);
  for (cv::Mat& depth : evidence.depths) depth.setTo(0);
  const render::TriangleMesh proxy = Sphere(kRadius);
  RefineReport report;
  const render::TriangleMesh refined = RefineWithDepthMaps(proxy, evidence, RefineOptions{}, 0.0, &report);
  EXPECT_LT(SphereError(refined).second, 0.0005);  // Taubin smoothing does not shrink it
  EXPECT_EQ(report.unseen_vertices, report.vertices);
}

// Median angle (degrees) between each face's normal and the sphere's there.
double MedianNormalErrorDeg(const render::TriangleMesh& mesh) {
  std::vector<double> angles;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.positions[t[0]].cast<double>(), b = mesh.positions[t[1]].cast<double>(),
                          c = mesh.positions[t[2]].cast<double>();
    const Eigen::Vector3d normal = (b - a).cross(c - a).normalized();
    const Eigen::Vector3d radial = ((a + b + c) / 3 - kCentre).normalized();
    angles.push_back(std::acos(std::clamp(normal.dot(radial), -1.0, 1.0)) * 180.0 / M_PI);
  }
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2];
}

TEST(VisibilityRefineTest, FinalSmoothingFlattensLumpsWithoutShrinking) {
  // Vertices pushed in or out by up to 1 mm, as the demo's depth noise
  // leaves them; no data iterations, so only the final passes act.
  render::TriangleMesh lumpy = Sphere(kRadius);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> bump(-0.001, 0.001);
  std::map<std::tuple<float, float, float>, double> bump_at;  // seam copies move together
  for (Eigen::Vector3f& p : lumpy.positions) {
    const auto key = std::make_tuple(p.x(), p.y(), p.z());
    if (!bump_at.count(key)) bump_at[key] = bump(rng);
    const Eigen::Vector3d radial = (p.cast<double>() - kCentre).normalized();
    p += (bump_at[key] * radial).cast<float>();
  }
  const DepthEvidence evidence = RingOfViews(0.0);
  RefineOptions options;
  options.iterations = 0;
  options.final_smoothing_iterations = 0;
  RefineReport report;
  const double before = MedianNormalErrorDeg(RefineWithDepthMaps(lumpy, evidence, options, 0.0, &report));
  options.final_smoothing_iterations = 20;
  const render::TriangleMesh smoothed = RefineWithDepthMaps(lumpy, evidence, options, 0.0, &report);
  const double after = MedianNormalErrorDeg(smoothed);
  std::printf("median normal error %.1f -> %.1f deg, mean radius error %.2f mm\n", before, after,
              1e3 * SphereError(smoothed).first);
  EXPECT_GT(before, 5.0);
  EXPECT_LT(after, 0.5 * before);
  EXPECT_LT(SphereError(smoothed).first, 0.0005);  // Taubin: no shrinkage
}

TEST(VisibilityRefineTest, MismatchedDepthMapsAreRejected) {
  DepthEvidence evidence = RingOfViews(0.0);
  evidence.depths[3] = cv::Mat(10, 10, CV_32F, cv::Scalar(0));
  RefineReport report;
  EXPECT_THROW(RefineWithDepthMaps(Sphere(kRadius), evidence, RefineOptions{}, 0.0, &report), Error);
}

}  // namespace
}  // namespace relit::reconstruct
