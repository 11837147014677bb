#include "core/render/light.h"

#include <cmath>

#include <gtest/gtest.h>

namespace relit::render {
namespace {

// Map: radiance `bright` inside a texel-aligned window of polar angle
// [theta0, theta1] and azimuth [phi0, phi1], `dim` elsewhere. Piecewise
// constant, so integrals over it are exact in closed form.
struct WindowMap {
  int width = 64, height = 32;
  int x0 = 8, x1 = 16, y0 = 4, y1 = 10;
  float bright = 50.0f, dim = 0.2f;
  Image image() const {
    Image map(width, height, 3, dim);
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        map.at(x, y, 0) = bright;
        map.at(x, y, 1) = 0.5f * bright;
        map.at(x, y, 2) = 0.25f * bright;
      }
    }
    return map;
  }
  // Irradiance on an upward-facing surface, red channel:
  // E = integral of L cos(theta) sin(theta) dtheta dphi over the upper hemisphere.
  double UpwardIrradianceRed() const {
    auto band = [](double t0, double t1) { return 0.5 * (std::pow(std::sin(t1), 2) - std::pow(std::sin(t0), 2)); };
    const double theta0 = M_PI * y0 / height, theta1 = M_PI * y1 / height;
    const double dphi = 2 * M_PI * (x1 - x0) / width;
    const double window = band(theta0, theta1) * dphi;
    const double hemisphere = band(0, M_PI / 2) * 2 * M_PI;  // = pi
    return dim * (hemisphere - window) + bright * window;
  }
};

TEST(EnvironmentLight, UvMappingRoundTripAndZUp) {
  EXPECT_NEAR(EnvironmentLight::DirectionToUv(Vec3f(0, 0, 1)).y(), 0.0f, 1e-6f);
  EXPECT_NEAR(EnvironmentLight::DirectionToUv(Vec3f(1, 0, 0)).x(), 0.0f, 1e-6f);
  EXPECT_NEAR(EnvironmentLight::DirectionToUv(Vec3f(0, 1, 0)).x(), 0.25f, 1e-6f);
  Rng rng(2, 2);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f d = SampleUniformSphere(rng.Uniform2());
    EXPECT_LT((EnvironmentLight::UvToDirection(EnvironmentLight::DirectionToUv(d)) - d).norm(), 1e-4f);
  }
}

TEST(EnvironmentLight, ImportanceSamplingConvergesToAnalyticIrradiance) {
  const WindowMap window;
  const EnvironmentLight env(window.image());
  const double reference = window.UpwardIrradianceRed();
  Rng rng(9, 9);
  const int n = 400000;
  double sum = 0, sum2 = 0, uniform_sum2 = 0, uniform_sum = 0;
  for (int i = 0; i < n; ++i) {
    float pdf = 0;
    const Vec3f d = env.Sample(rng.Uniform2(), &pdf);
    ASSERT_GT(pdf, 0);
    ASSERT_NEAR(pdf, env.Pdf(d), 1e-3f * pdf + 1e-6f);
    const double v = d.z() > 0 ? env.Eval(d)[0] * d.z() / pdf : 0.0;
    sum += v;
    sum2 += v * v;
    // Uniform sphere sampling of the same integral, for comparison.
    const Vec3f du = SampleUniformSphere(rng.Uniform2());
    const double vu = du.z() > 0 ? env.Eval(du)[0] * du.z() * 4 * M_PI : 0.0;
    uniform_sum += vu;
    uniform_sum2 += vu * vu;
  }
  const double mean = sum / n;
  const double stderr_ = std::sqrt((sum2 / n - mean * mean) / n);
  EXPECT_LT(std::abs(mean - reference), 4 * stderr_) << mean << " vs " << reference;
  EXPECT_LT(std::abs(mean - reference), 0.01 * reference);
  // Importance sampling must beat uniform sampling clearly on this peaky map.
  const double uniform_var = uniform_sum2 / n - std::pow(uniform_sum / n, 2);
  EXPECT_LT(sum2 / n - mean * mean, 0.5 * uniform_var);
}

TEST(EnvironmentLight, RotationTurnsTheMap) {
  const WindowMap window;
  const EnvironmentLight turned(window.image(), 1.0f, static_cast<float>(M_PI / 2));
  const EnvironmentLight plain(window.image());
  Rng rng(4, 4);
  for (int i = 0; i < 100; ++i) {
    const Vec3f d = SampleUniformSphere(rng.Uniform2());
    const Vec3f d_turned(-d.y(), d.x(), d.z());  // d rotated by +90 degrees about z
    EXPECT_NEAR(turned.Eval(d_turned)[0], plain.Eval(d)[0], 1e-5f);
  }
}

TEST(EnvironmentLight, RejectsNegativeValues) {
  Image map(4, 2, 3, 1.0f);
  map.at(1, 1, 2) = -1.0f;
  EXPECT_THROW(EnvironmentLight{map}, std::runtime_error);
}

}  // namespace
}  // namespace relit::render
