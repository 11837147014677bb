#include "reconstruct/proxy_normals.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "core/camera.h"
#include "core/median.h"
#include "core/render/scene.h"
#include "core/test_dir.h"

namespace relit::reconstruct {
namespace {

// A Lambertian sphere (albedo 0.6) filmed by 24 cameras on two rings, each
// frame lit by its own point light of unit intensity somewhere above; the
// images are exact (ray-sphere intersection, no shadows on a convex body).
// The proxy is the same sphere, coarser, with every vertex normal turned
// 25 deg in a random direction: its shading is wrong the way a lumpy proxy's
// is, while the texels sit on the true surface.
class ProxyNormalsTest : public test_support::TempDirTest {
 protected:
  ProxyNormalsTest() : TempDirTest("relit_proxy_normals_") {}

  const Eigen::Vector3d centre_{0, 0, 0.06};
  const double radius_ = 0.05;

  bool mirror_ = false;  // render a glossy black sphere instead (RenderSphere)

  void MakeCapture(CamerasFile* cameras, LightsFile* lights) {
    cameras->undistorted_view = Intrinsics::FromFov(160, 120, 0.45);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0, 1);
    std::filesystem::create_directories(root_ / "calib" / "images");
    for (int i = 0; i < 24; ++i) {
      const double azimuth = 2 * M_PI * i / 12, elevation = (i < 12 ? 20 : 50) * M_PI / 180;
      const Eigen::Vector3d eye =
          centre_ + 0.4 * Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                                          std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
      const double light_azimuth = azimuth + (unit(rng) - 0.5) * 2.0;
      const double light_elevation = (15 + 60 * unit(rng)) * M_PI / 180;
      const Eigen::Vector3d light =
          centre_ + 0.35 * Eigen::Vector3d(std::cos(light_elevation) * std::cos(light_azimuth),
                                           std::cos(light_elevation) * std::sin(light_azimuth),
                                           std::sin(light_elevation));
      CalibratedFrame frame;
      frame.name = "view/" + std::to_string(100000 + i).substr(1);
      frame.device = "view";
      frame.cam_from_world = LookAt(eye, centre_, Eigen::Vector3d::UnitZ());
      frame.image_linear = "calib/images/" + std::to_string(i) + ".exr";
      WriteImage((root_ / frame.image_linear).string(), RenderSphere(Camera(cameras->undistorted_view,
                                                                            frame.cam_from_world), light),
                 PixelStorage::kFloat);
      cameras->frames.push_back(frame);
      FrameLight fl;
      fl.view_frame = frame.name;
      fl.position_m = light;
      lights->frames.push_back(fl);
    }
  }

  Image RenderSphere(const Camera& camera, const Eigen::Vector3d& light) const {
    const int w = camera.intrinsics().width, h = camera.intrinsics().height;
    Image image(w, h, 3);
    const Eigen::Vector3d origin = camera.Center();
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const Eigen::Vector3d d = camera.PixelToWorldRay({x, y});
        const Eigen::Vector3d oc = origin - centre_;
        const double b = oc.dot(d), c = oc.squaredNorm() - radius_ * radius_, disc = b * b - c;
        if (disc < 0) continue;
        const Eigen::Vector3d p = origin + (-b - std::sqrt(disc)) * d;
        const Eigen::Vector3d n = (p - centre_).normalized();
        const Eigen::Vector3d to_light = light - p;
        double value = 0.6 * 0.05 * std::max(0.0, n.dot(to_light.normalized())) / to_light.squaredNorm();
        if (mirror_) {  // a reflection of a patterned room and a narrow highlight (Blinn-Phong, exponent 300)
          const Eigen::Vector3d half = (to_light.normalized() - d).normalized();
          const Eigen::Vector3d r = d - 2 * d.dot(n) * n;
          value = 0.01 * (1.5 + std::sin(6 * r.x()) * std::cos(4 * r.y()) + r.z()) +
                  0.03 * std::pow(std::max(0.0, n.dot(half)), 300) / to_light.squaredNorm();
        }
        for (int ch = 0; ch < 3; ++ch) image.at(x, y, ch) = static_cast<float>(value);
      }
    }
    return image;
  }

  render::TriangleMesh MakeProxy(double turn_deg = 25) const {
    render::TriangleMesh proxy = render::MakeSphere(centre_.cast<float>(), static_cast<float>(radius_), 16, 8);
    std::mt19937 rng(3);
    std::normal_distribution<float> gauss(0, 1);
    for (Eigen::Vector3f& n : proxy.normals) {
      Eigen::Vector3f side = n.cross(Eigen::Vector3f(gauss(rng), gauss(rng), gauss(rng))).normalized();
      const float turn = static_cast<float>(turn_deg * M_PI / 180);
      n = (std::cos(turn) * n + std::sin(turn) * side).normalized();
    }
    return proxy;
  }

  double MedianErrorWithMap(const render::TriangleMesh& proxy, const Image* map) const {
    render::Material material = render::Material::Lambert(render::Rgb::Constant(0.5f));
    if (map != nullptr) material.normal_map = render::Texture::FromImage(*map, false);
    render::Scene scene;
    scene.AddObject(proxy, material, 1);
    scene.Commit();
    return MedianNormalError(scene);
  }

  // Median angle (deg) between the shading normal `scene` gives and the
  // sphere's true normal, over the pixels of a view between the rings.
  double MedianNormalError(const render::Scene& scene) const {
    const Camera camera(Intrinsics::FromFov(160, 120, 0.45),
                        LookAt(centre_ + 0.4 * Eigen::Vector3d(0.8, 0.3, 0.5).normalized(), centre_,
                               Eigen::Vector3d::UnitZ()));
    std::vector<double> errors;
    for (int y = 0; y < 120; ++y) {
      for (int x = 0; x < 160; ++x) {
        render::Hit hit;
        if (!scene.Intersect(camera.Center().cast<float>(), camera.PixelToWorldRay({x, y}).cast<float>(), 0, 10,
                             &hit)) {
          continue;
        }
        const Eigen::Vector3f truth = (hit.position - centre_.cast<float>()).normalized();
        errors.push_back(std::acos(std::clamp(hit.shading_normal.dot(truth), -1.0f, 1.0f)) * 180 / M_PI);
      }
    }
    EXPECT_GT(errors.size(), 500u);
    return Median(errors);
  }
};

TEST_F(ProxyNormalsTest, FlashFramesRecoverTheNormalsAProxyGetsWrong) {
  CamerasFile cameras;
  LightsFile lights;
  MakeCapture(&cameras, &lights);
  const render::TriangleMesh proxy = MakeProxy();
  NormalMapOptions options;
  options.resolution_px = 32;
  NormalMapStats stats;
  const Image map =
      EstimateNormalMap(root_.string(), cameras, lights, cameras.FramesOf("view"), proxy, options, &stats);
  EXPECT_EQ(stats.frames, 24);
  EXPECT_GT(stats.texels_estimated, stats.texels_seen / 2);

  render::Scene without;
  without.AddObject(proxy, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  without.Commit();
  render::Material mapped = render::Material::Lambert(render::Rgb::Constant(0.5f));
  mapped.normal_map = render::Texture::FromImage(map, false);
  render::Scene with;
  with.AddObject(proxy, mapped, 1);
  with.Commit();
  const double before = MedianNormalError(without), after = MedianNormalError(with);
  std::cout << "median normal error: proxy " << before << " deg, with the normal map " << after << " deg; "
            << stats.ToJson().dump() << "\n";
  // Measured 18.8 -> 8.3 deg (the prior's pull towards the wrong normals and
  // the 32^2 texels' constant normal on a curved surface keep the rest).
  EXPECT_GT(before, 15.0);
  EXPECT_LT(after, 10.0);
  EXPECT_LT(after, before / 2);
}

TEST_F(ProxyNormalsTest, GlossyTexelsKeepTheProxyNormal) {
  // A mirror-like sphere and an exact proxy: the Lambert fit explains little
  // of each texel's data (a dim constant, a highlight in a frame or two), so
  // its normals would be noise.
  mirror_ = true;
  CamerasFile cameras;
  LightsFile lights;
  MakeCapture(&cameras, &lights);
  const render::TriangleMesh proxy = MakeProxy(0);
  NormalMapOptions options;
  options.resolution_px = 32;
  NormalMapStats gated, ungated;
  const Image map = EstimateNormalMap(root_.string(), cameras, lights, cameras.FramesOf("view"), proxy, options, &gated);
  options.min_explained_variance = 0;  // both gates off: every fit taken, as before they existed
  options.max_residual_ratio = 1;
  const Image noise =
      EstimateNormalMap(root_.string(), cameras, lights, cameras.FramesOf("view"), proxy, options, &ungated);
  const double exact = MedianErrorWithMap(proxy, nullptr), with_gate = MedianErrorWithMap(proxy, &map),
               without_gate = MedianErrorWithMap(proxy, &noise);
  std::cout << "median normal error: proxy " << exact << " deg, gated map " << with_gate << " deg, ungated "
            << without_gate << " deg; " << gated.ToJson().dump() << "\n";
  EXPECT_GT(gated.texels_estimated, 100);
  EXPECT_GT(gated.texels_not_lambert, gated.texels_estimated * 4 / 10);  // the rest fit no positive albedo
  EXPECT_EQ(ungated.texels_not_lambert, 0);
  EXPECT_LT(with_gate, exact + 1.0);
  EXPECT_GT(without_gate, exact + 3.0);  // what the gate prevents
}

TEST_F(ProxyNormalsTest, UnlitTexelsKeepTheProxyNormal) {
  CamerasFile cameras;
  LightsFile lights;
  MakeCapture(&cameras, &lights);
  lights.frames.clear();  // no flash position: nothing is observed lit
  NormalMapOptions options;
  options.resolution_px = 32;
  NormalMapStats stats;
  const render::TriangleMesh proxy = MakeProxy();
  EstimateNormalMap(root_.string(), cameras, lights, cameras.FramesOf("view"), proxy, options, &stats);
  EXPECT_EQ(stats.frames, 0);
  EXPECT_EQ(stats.texels_estimated, 0);
}

}  // namespace
}  // namespace relit::reconstruct
