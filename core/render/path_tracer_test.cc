#include "core/render/path_tracer.h"

#include <atomic>
#include <cmath>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

namespace relit::render {
namespace {

Camera LookingAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int size, double fov_deg,
                 const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ()) {
  return Camera(Intrinsics::FromFov(size, size, fov_deg * M_PI / 180.0), LookAt(eye, target, up));
}

struct PixelStats {
  double mean = 0, stderr_ = 0;
  int count = 0;
};

// Mean and standard error of channel c over pixels fully covered by objects.
PixelStats CoveredMean(const RenderResult& r, int c) {
  double sum = 0, sum2 = 0;
  int n = 0;
  for (int y = 0; y < r.radiance.height(); ++y) {
    for (int x = 0; x < r.radiance.width(); ++x) {
      if (r.alpha.at(x, y, 0) < 1.0f) continue;
      const double v = r.radiance.at(x, y, c);
      sum += v;
      sum2 += v * v;
      ++n;
    }
  }
  PixelStats s;
  s.count = n;
  s.mean = sum / n;
  s.stderr_ = std::sqrt(std::max(0.0, sum2 / n - s.mean * s.mean) / n);
  return s;
}

TEST(PathTracer, WhiteFurnace) {
  // An albedo-1 Lambert sphere inside a uniform white environment reflects
  // exactly the incident radiance: every covered pixel converges to 1.
  Scene scene;
  scene.AddObject(MakeSphere(Eigen::Vector3f::Zero(), 0.5f, 256, 128), Material::Lambert(Rgb::Ones()), 1);
  scene.SetEnvironment(EnvironmentLight(Image(16, 8, 3, 1.0f)));
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 16;
  options.max_depth = 16;
  const RenderResult r = RenderImage(scene, LookingAt({0, -2, 0.3}, {0, 0, 0}, 32, 40), options);
  for (int c = 0; c < 3; ++c) {
    const PixelStats s = CoveredMean(r, c);
    ASSERT_GT(s.count, 200);
    EXPECT_NEAR(s.mean, 1.0, 4 * s.stderr_ + 0.005) << "channel " << c;
  }
}

TEST(PathTracer, LambertPlaneUnderPointLightMatchesAnalyticIrradiance) {
  const float albedo = 0.6f;
  const Rgb intensity(1.0f, 2.0f, 3.0f);
  const Vec3f light(0.1f, -0.2f, 0.5f);
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1, 1), Material::Lambert(Rgb::Constant(albedo)), 1);
  scene.AddLight(PointLight{light, intensity});
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 64;
  const Camera camera = LookingAt({0, 0, 1.5}, {0, 0, 0}, 48, 50, Eigen::Vector3d::UnitY());
  const RenderResult r = RenderImage(scene, camera, options);
  // Reference: the analytic radiance averaged over the pixel footprint
  // (box filter) by a fine 16x16 grid of rays meeting the plane z = 0.
  auto analytic = [&](double px, double py, int c) {
    const Eigen::Vector3d ray = camera.PixelToWorldRay({px, py});
    const Eigen::Vector3d o = camera.Center();
    const Vec3f p = (o - (o.z() / ray.z()) * ray).cast<float>();
    const Vec3f d = light - p;
    return albedo / kPi * intensity[c] * (d.z() / d.norm()) / d.squaredNorm();
  };
  int checked = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 48; ++x) {
      if (r.alpha.at(x, y, 0) < 1) continue;
      for (int c = 0; c < 3; ++c) {
        double expected = 0;
        for (int i = 0; i < 16; ++i) {
          for (int j = 0; j < 16; ++j) expected += analytic(x - 0.5 + (i + 0.5) / 16, y - 0.5 + (j + 0.5) / 16, c);
        }
        expected /= 256;
        EXPECT_NEAR(r.radiance.at(x, y, c), expected, 0.003 * expected) << x << "," << y;
      }
      ++checked;
    }
  }
  EXPECT_GT(checked, 1500);
}

TEST(PathTracer, DirectionalLightOnTiltedPlane) {
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1, 1), Material::Lambert(Rgb(0.5f, 0.25f, 1.0f)), 1);
  const Vec3f to_light = Vec3f(0.3f, 0.2f, 0.8f).normalized();
  scene.AddLight(DirectionalLight{to_light, Rgb(2, 2, 2)});
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 1;
  const RenderResult r = RenderImage(scene, LookingAt({0.2, -0.5, 1.0}, {0, 0, 0}, 16, 40), options);
  const PixelStats s = CoveredMean(r, 2);
  ASSERT_GT(s.count, 100);
  EXPECT_NEAR(s.mean, 1.0 / M_PI * 2 * to_light.z(), 1e-4);
}

TEST(PathTracer, SmallQuadLightActsLikePointLight) {
  // A 1 cm quad of radiance L at 0.4 m is a point light of intensity
  // L * A * cos(angle from its normal), to well under 1%.
  const float side = 0.01f, height = 0.4f;
  const Rgb radiance = Rgb::Constant(2e4f);
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.5f, 0.5f), Material::Lambert(Rgb::Constant(0.5f)), 1);
  QuadLight quad;
  quad.corner = Vec3f(-side / 2, -side / 2, height);
  quad.edge_u = Vec3f(0, side, 0);  // edge_u x edge_v = -z: emits downwards
  quad.edge_v = Vec3f(side, 0, 0);
  quad.radiance = radiance;
  scene.AddLight(quad);
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 16;
  const RenderResult r = RenderImage(scene, LookingAt({0.3, -0.3, 0.8}, {0, 0, 0}, 24, 40), options);
  int checked = 0;
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      if (r.alpha.at(x, y, 0) < 1) continue;
      const Vec3f p(r.position.at(x, y, 0), r.position.at(x, y, 1), r.position.at(x, y, 2));
      const Vec3f d = Vec3f(0, 0, height) - p;
      const float cos_r = d.z() / d.norm();  // at the receiver and at the light
      const float expected = 0.5f / kPi * radiance[0] * side * side * cos_r * cos_r / d.squaredNorm();
      EXPECT_NEAR(r.radiance.at(x, y, 0), expected, 0.02f * expected);
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(PathTracer, EnvironmentLitPlaneMatchesAnalyticIntegral) {
  // Texel-aligned bright window in a dim map: irradiance on an upward plane
  // has a closed form (see light_test.cc); radiance = albedo / pi * E.
  Image map(64, 32, 3, 0.2f);
  for (int y = 4; y < 10; ++y) {
    for (int x = 8; x < 16; ++x) {
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = 50.0f;
    }
  }
  auto band = [](double t0, double t1) { return 0.5 * (std::pow(std::sin(t1), 2) - std::pow(std::sin(t0), 2)); };
  const double window = band(M_PI * 4 / 32, M_PI * 10 / 32) * 2 * M_PI * 8 / 64;
  const double irradiance = 0.2 * (M_PI - window) + 50.0 * window;
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1, 1), Material::Lambert(Rgb::Constant(0.7f)), 1);
  scene.SetEnvironment(EnvironmentLight(map));
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 64;
  const RenderResult r = RenderImage(scene, LookingAt({0, 0, 1.0}, {0, 0, 0}, 16, 30, Eigen::Vector3d::UnitY()), options);
  const PixelStats s = CoveredMean(r, 0);
  ASSERT_EQ(s.count, 256);
  const double expected = 0.7 / M_PI * irradiance;
  EXPECT_NEAR(s.mean, expected, 4 * s.stderr_ + 0.002 * expected);
}

TEST(PathTracer, GlobalIlluminationAddsLight) {
  // Plane plus a white wall: indirect light from the wall brightens the floor.
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.5f, 0.5f), Material::Lambert(Rgb::Constant(0.5f)), 1);
  scene.AddObject(MakeQuad(Vec3f(0, 0.3f, 0.3f), Vec3f::UnitX(), -Vec3f::UnitZ(), 0.5f, 0.3f), Material::Lambert(Rgb::Constant(0.9f)), 2);
  scene.AddLight(PointLight{Vec3f(0, 0.1f, 0.4f), Rgb::Ones()});
  scene.Commit();
  RenderOptions direct, global;
  direct.samples_per_pixel = global.samples_per_pixel = 64;
  direct.max_depth = 1;
  global.max_depth = 8;
  const Camera camera = LookingAt({0, -0.6, 0.5}, {0, 0, 0}, 16, 40);
  const double d = CoveredMean(RenderImage(scene, camera, direct), 0).mean;
  const double g = CoveredMean(RenderImage(scene, camera, global), 0).mean;
  EXPECT_GT(g, d * 1.05);
}

Scene& SharedSphereScene() {
  static Scene* scene = [] {
    auto* s = new Scene;
    s->AddObject(MakeSphere(Eigen::Vector3f::Zero(), 0.3f), Material::Glossy(Rgb(0.4f, 0.3f, 0.2f), Rgb::Ones(), 0.1f), 7);
    s->AddObject(MakeQuad(Vec3f(0, 0, -0.3f), Vec3f::UnitX(), Vec3f::UnitY(), 1, 1), Material::Lambert(Rgb::Constant(0.5f)), 8);
    s->AddLight(PointLight{Vec3f(0.5f, -0.5f, 1.0f), Rgb::Constant(2.0f)});
    s->Commit();
    return s;
  }();
  return *scene;
}

TEST(PathTracer, DeterministicForSeedAndThreadCount) {
  RenderOptions options;
  options.samples_per_pixel = 4;
  options.seed = 123;
  const Camera camera = LookingAt({0, -1.5, 0.8}, {0, 0, 0}, 24, 40);
  const RenderResult a = RenderImage(SharedSphereScene(), camera, options);
  RenderResult b;
  {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    b = RenderImage(SharedSphereScene(), camera, options);
  }
  EXPECT_EQ(a.radiance.data(), b.radiance.data());
  options.seed = 124;
  const RenderResult c = RenderImage(SharedSphereScene(), camera, options);
  EXPECT_NE(a.radiance.data(), c.radiance.data());
}

TEST(PathTracer, AlphaAndObjectIds) {
  RenderOptions options;
  options.samples_per_pixel = 16;
  options.alpha_object_ids = {7};
  const Camera camera = LookingAt({0, -1.5, 0}, {0, 0, 0}, 32, 40);
  const RenderResult r = RenderImage(SharedSphereScene(), camera, options);
  EXPECT_EQ(r.alpha.at(16, 16, 0), 1.0f);          // sphere centre
  EXPECT_EQ(r.object_id.at(16, 16, 0), 7.0f);
  EXPECT_EQ(r.alpha.at(16, 31, 0), 0.0f);          // floor: not an alpha object
  EXPECT_EQ(r.object_id.at(16, 31, 0), 8.0f);
  EXPECT_EQ(r.object_id.at(0, 0, 0), -1.0f);       // background
  // Partial coverage exists along the silhouette (antialiased alpha).
  int partial = 0;
  for (float a : r.alpha.data()) partial += (a > 0 && a < 1);
  EXPECT_GT(partial, 10);
  // Depth is camera z of the hit: sphere front at distance 1.5 - 0.3.
  EXPECT_NEAR(r.depth.at(16, 16, 0), 1.2f, 0.01f);
}

TEST(PathTracer, DistortedCameraAovsReprojectToTheirPixels) {
  Intrinsics k = Intrinsics::FromFov(40, 30, 1.2);
  k.distortion = {0.15, -0.1, 0.001, 0.002, 0.0};
  const Camera camera(k, LookAt({0.3, -1.2, 0.6}, {0, 0, 0}, {0, 0, 1}));
  RenderOptions options;
  options.samples_per_pixel = 1;
  const RenderResult r = RenderImage(SharedSphereScene(), camera, options);
  int checked = 0;
  for (int y = 0; y < 30; ++y) {
    for (int x = 0; x < 40; ++x) {
      if (r.object_id.at(x, y, 0) < 0) continue;
      Eigen::Vector2d pixel;
      const Eigen::Vector3d p(r.position.at(x, y, 0), r.position.at(x, y, 1), r.position.at(x, y, 2));
      ASSERT_TRUE(camera.Project(p, &pixel));
      EXPECT_NEAR(pixel.x(), x, 1e-2);
      EXPECT_NEAR(pixel.y(), y, 1e-2);
      ++checked;
    }
  }
  EXPECT_GT(checked, 600);
}

TEST(PathTracer, UvDerivativesOfFrontoParallelQuad) {
  // A 0.5 m quad at 1 m filling a known number of pixels: u changes by
  // 1 / (quad width in pixels) per pixel step in x, v by -1 / height in y.
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.25f, 0.25f), Material::Lambert(Rgb::Ones()), 1);
  scene.Commit();
  const Intrinsics k = Intrinsics::FromFov(64, 64, 2 * std::atan(0.5));  // fx = 64 px
  // Camera above looking down, image x along world +x, image y along world -y.
  const Camera camera(k, LookAt({0, 0, 1}, {0, 0, 0}, {0, 1, 0}));
  RenderOptions options;
  options.samples_per_pixel = 1;
  const RenderResult r = RenderImage(scene, camera, options);
  const float quad_px = 0.5f * 64.0f;  // 0.5 m at 1 m with fx = 64 px
  EXPECT_NEAR(r.uv_derivatives.at(32, 32, 0), 1.0f / quad_px, 1e-4f);   // du/dx
  EXPECT_NEAR(r.uv_derivatives.at(32, 32, 1), 0.0f, 1e-5f);             // dv/dx
  EXPECT_NEAR(r.uv_derivatives.at(32, 32, 2), 0.0f, 1e-5f);             // du/dy
  EXPECT_NEAR(r.uv_derivatives.at(32, 32, 3), -1.0f / quad_px, 1e-4f);  // dv/dy
}

TEST(PathTracer, RejectsBadOptions) {
  RenderOptions options;
  options.samples_per_pixel = 0;
  EXPECT_THROW(options.Check(), std::runtime_error);
  options = RenderOptions();
  options.max_depth = 0;
  EXPECT_THROW(options.Check(), std::runtime_error);
}

}  // namespace
}  // namespace relit::render

namespace relit::render {
namespace {

class CountingObserver : public RayObserver {
 public:
  void OnRay(const Vec3f&, const Vec3f&, float, float, bool occlusion) override {
    (occlusion ? occluded : intersected).fetch_add(1, std::memory_order_relaxed);
  }
  std::atomic<uint64_t> intersected{0}, occluded{0};
};

TEST(PathTracer, RayObserverSeesEveryRay) {
  // A plane under a point light with max_depth 1: per sample one camera ray
  // (shared by alpha and shading), one shadow ray on a hit and one BSDF ray
  // (which may stop early); plus one pixel-centre AOV ray per pixel.
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 5, 5), Material::Lambert(Rgb::Ones()), 1);
  scene.AddLight(PointLight{Vec3f(0, 0, 1), Rgb::Ones()});
  scene.Commit();
  CountingObserver observer;
  scene.set_ray_observer(&observer);
  RenderOptions options;
  options.samples_per_pixel = 4;
  options.max_depth = 1;
  RenderImage(scene, LookingAt({0, 0, 1}, {0, 0, 0}, 8, 40, Eigen::Vector3d::UnitY()), options);
  const uint64_t pixels = 64, samples = pixels * 4;
  EXPECT_EQ(observer.occluded.load(), samples);                 // every sample hits the plane
  EXPECT_EQ(observer.intersected.load(), samples + pixels + samples);  // camera + AOV + continuation
}

}  // namespace
}  // namespace relit::render
