// Photometric surface refinement on a scene with a closed-form answer: a
// sphere with dark spots (sharp albedo edges, like the cow's patches) above
// a table, seen by two rings of cameras whose images are ray-traced
// analytically under a flash that moves from frame to frame.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/render/mesh.h"
#include "reconstruct/surface_photo_refine.h"
#include "reconstruct/test_workspace.h"

namespace relit::reconstruct {
namespace {

const Eigen::Vector3d kCentre(0.01, -0.02, 0.05);
constexpr double kRadius = 0.03;

// Albedo: white with dark round spots 3-8 mm across, and a faint ramp.
double Albedo(const Eigen::Vector3d& p) {
  static const std::vector<std::pair<Eigen::Vector3d, double>> spots = [] {
    std::mt19937 rng(3);
    std::normal_distribution<double> normal;
    std::uniform_real_distribution<double> size(0.0015, 0.004);
    std::vector<std::pair<Eigen::Vector3d, double>> s;
    for (int i = 0; i < 160; ++i) {
      const Eigen::Vector3d d = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      s.push_back({kCentre + kRadius * d, size(rng)});
    }
    return s;
  }();
  for (const auto& [centre, radius] : spots) {
    if ((p - centre).norm() < radius) return 0.08;
  }
  return 0.8 + 0.1 * std::sin(40.0 * p.z());
}

// A grey frame: the sphere (else the table, with its own spots) under a
// point light at `flash`, Lambert, 8-bit.
cv::Mat RenderFrame(const Camera& camera, const Eigen::Vector3d& flash) {
  const Intrinsics& k = camera.intrinsics();
  cv::Mat gray(k.height, k.width, CV_8U, cv::Scalar(0));
  const Eigen::Vector3d eye = camera.Center();
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d ray = camera.PixelToWorldRay(Eigen::Vector2d(u, v));
      const double t = testing::RaySphere(eye, ray, kCentre, kRadius);
      Eigen::Vector3d hit, normal;
      if (t > 0) {
        hit = eye + t * ray;
        normal = (hit - kCentre) / kRadius;
      } else if (ray.z() < 0) {
        hit = eye + (-eye.z() / ray.z()) * ray;
        normal = Eigen::Vector3d::UnitZ();
      } else {
        continue;
      }
      const Eigen::Vector3d to_light = flash - hit;
      const double shading = std::max(0.0, normal.dot(to_light.normalized())) * 0.16 / to_light.squaredNorm();
      gray.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(255.0 * Albedo(hit) * shading);
    }
  }
  return gray;
}

struct Frames {
  std::vector<Camera> cameras;
  std::vector<cv::Mat> grays;
};

// Two rings of cameras; each frame's flash sits 12 cm beside its camera,
// on a side that changes from frame to frame (the moving phone L).
Frames RenderFrames() {
  Frames frames;
  frames.cameras = testing::TwoRingsOfCameras(kCentre, 20.0, 50.0);
  for (size_t i = 0; i < frames.cameras.size(); ++i) {
    const Camera& camera = frames.cameras[i];
    const double angle = 2.4 * static_cast<double>(i);
    const Eigen::Vector3d side = camera.world_from_cam().rotation * Eigen::Vector3d(std::cos(angle), std::sin(angle), 0);
    frames.grays.push_back(RenderFrame(camera, camera.Center() + 0.12 * side));
  }
  return frames;
}

// Mean distance (or signed offset, + outside) of the vertices above the
// sphere's equator from the true sphere (the rings see the lower half at
// grazing angles or not at all).
double UpperError(const render::TriangleMesh& mesh, bool signed_offset = false) {
  double sum = 0;
  int count = 0;
  for (const Eigen::Vector3f& p : mesh.positions) {
    if (p.z() < kCentre.z() + 0.3 * kRadius) continue;
    const double offset = (p.cast<double>() - kCentre).norm() - kRadius;
    sum += signed_offset ? offset : std::abs(offset);
    ++count;
  }
  return sum / count;
}

render::TriangleMesh Sphere(double radius) { return render::MakeSphere(kCentre.cast<float>(), radius, 48, 24); }

TEST(SurfacePhotoRefineTest, AnOffsetProxyMovesOntoTheTexturedSurface) {
  const Frames frames = RenderFrames();
  for (double offset_m : {0.0015, -0.0015}) {
    const render::TriangleMesh proxy = Sphere(kRadius + offset_m);
    ASSERT_NEAR(UpperError(proxy), std::abs(offset_m), 1e-4);
    SurfacePhotoReport report;
    const render::TriangleMesh refined =
        RefineSurfacePhotometric(proxy, frames.cameras, frames.grays, SurfacePhotoOptions{}, 0.0, &report);
    EXPECT_GT(report.measured_vertices_first, 100);
    EXPECT_LT(UpperError(refined), 0.4e-3) << "offset " << offset_m;  // from 1.5 mm (1.5 px)
  }
}

TEST(SurfacePhotoRefineTest, TheTrueSurfaceStaysPut) {
  const Frames frames = RenderFrames();
  const render::TriangleMesh proxy = Sphere(kRadius);
  SurfacePhotoOptions curved, flat;
  flat.curved_patch = false;
  SurfacePhotoReport report;
  const render::TriangleMesh refined = RefineSurfacePhotometric(proxy, frames.cameras, frames.grays, curved, 0.0, &report);
  const render::TriangleMesh refined_flat =
      RefineSurfacePhotometric(proxy, frames.cameras, frames.grays, flat, 0.0, &report);
  const double bias_m = UpperError(refined, true), flat_bias_m = UpperError(refined_flat, true);
  // A flat 9 mm patch stands out of a 3 cm sphere by up to 0.5 mm at its
  // corners: its optimum sinks into the surface. The patch that follows
  // the surface does not.
  EXPECT_LT(flat_bias_m, -0.1e-3);
  EXPECT_LT(std::abs(bias_m), 0.4 * std::abs(flat_bias_m)) << bias_m << " vs flat " << flat_bias_m;
  EXPECT_LT(UpperError(refined), 0.12e-3);
}

TEST(SurfacePhotoRefineTest, RefusesFramesThatDoNotMatchTheirCameras) {
  Frames frames = RenderFrames();
  frames.grays.pop_back();
  SurfacePhotoReport report;
  EXPECT_THROW(RefineSurfacePhotometric(Sphere(kRadius), frames.cameras, frames.grays, SurfacePhotoOptions{}, 0.0,
                                        &report),
               Error);
}

}  // namespace
}  // namespace relit::reconstruct
