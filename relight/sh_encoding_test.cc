// The sh baseline's encoding: spherical-harmonics values against closed forms
// and orthonormality by quadrature, the environment projection, per-pixel
// features of point / directional lights.
#include "relight/sh_encoding.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"

namespace relit::relight {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d Direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// The general real SH formula (no Condon-Shortley phase; std::assoc_legendre
// has none): K_l^m P_l^|m|(cos theta) x (sqrt 2 cos(m phi) | sqrt 2 sin(|m| phi) | 1).
double GeneralReal(int l, int m, double theta, double phi) {
  auto factorial = [](int n) { return std::tgamma(n + 1.0); };
  const int am = std::abs(m);
  const double k = std::sqrt((2 * l + 1) / (4 * kPi) * factorial(l - am) / factorial(l + am));
  const double p = std::assoc_legendre(l, am, std::cos(theta));
  if (m > 0) return std::sqrt(2.0) * k * p * std::cos(m * phi);
  if (m < 0) return std::sqrt(2.0) * k * p * std::sin(am * phi);
  return k * p;
}

TEST(ShEncoding, MatchesTheGeneralFormula) {
  const int lm[kShCoefficientCount][2] = {{0, 0}, {1, -1}, {1, 0}, {1, 1}, {2, -2}, {2, -1}, {2, 0}, {2, 1}, {2, 2}};
  for (double theta : {0.0, 0.3, 1.1, 1.9, 3.0}) {
    for (double phi : {0.0, 0.7, 2.5, 4.4}) {
      const auto y = ShBasis(Direction(theta, phi));
      for (int k = 0; k < kShCoefficientCount; ++k) {
        EXPECT_NEAR(y[k], GeneralReal(lm[k][0], lm[k][1], theta, phi), 1e-12) << "k " << k;
      }
    }
  }
  // Known values: Y00 = 1 / (2 sqrt(pi)); Y20 at the pole = sqrt(5 / (4 pi)).
  EXPECT_NEAR(ShBasis({0, 0, 1})[0], 0.5 / std::sqrt(kPi), 1e-15);
  EXPECT_NEAR(ShBasis({0, 0, 1})[6], std::sqrt(5 / (4 * kPi)), 1e-12);
}

TEST(ShEncoding, OrthonormalOverTheSphere) {
  // Gauss-Legendre in cos(theta) (exact for these polynomials with 8 nodes)
  // times a uniform phi grid (exact for trigonometric degree < 32).
  const double nodes[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290, -0.1834346424956498,
                           0.1834346424956498,  0.5255324099163290,  0.7966664774136267,  0.9602898564975363};
  const double weights[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873, 0.3626837833783620,
                             0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
  const int phis = 32;
  double gram[kShCoefficientCount][kShCoefficientCount] = {};
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < phis; ++j) {
      const double theta = std::acos(nodes[i]), phi = 2 * kPi * (j + 0.25) / phis;
      const auto y = ShBasis(Direction(theta, phi));
      const double w = weights[i] * 2 * kPi / phis;
      for (int a = 0; a < kShCoefficientCount; ++a) {
        for (int b = 0; b < kShCoefficientCount; ++b) gram[a][b] += w * y[a] * y[b];
      }
    }
  }
  for (int a = 0; a < kShCoefficientCount; ++a) {
    for (int b = 0; b < kShCoefficientCount; ++b) EXPECT_NEAR(gram[a][b], a == b ? 1.0 : 0.0, 1e-9) << a << "," << b;
  }
}

render::EnvironmentLight MapOf(double (*radiance)(const Eigen::Vector3d&), int height = 64) {
  Image map(2 * height, height, std::vector<std::string>{"R", "G", "B"});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < 2 * height; ++x) {
      const render::Vec3f d = render::EnvironmentLight::UvToDirection(
          render::Vec2f((x + 0.5f) / (2 * height), (y + 0.5f) / height));
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = static_cast<float>(radiance(d.cast<double>()) * (c + 1));
    }
  }
  return render::EnvironmentLight(map);
}

TEST(ShEncoding, EnvironmentProjection) {
  // L = 1 + z (per channel x 1, 2, 3): int L = 4 pi, int L Y10 = sqrt(3 / (4 pi)) 4 pi / 3.
  const ShProjection p = ProjectEnvironment(MapOf([](const Eigen::Vector3d& d) { return 1.0 + d.z(); }));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(p.integral[c], 4 * kPi * (c + 1), 0.02 * (c + 1));
    EXPECT_NEAR(p.coefficients[2][c], std::sqrt(3 / (4 * kPi)) * 4 * kPi / 3 * (c + 1), 0.02 * (c + 1));
    EXPECT_NEAR(p.coefficients[0][c], 2 * std::sqrt(kPi) * (c + 1), 0.02 * (c + 1));
    for (int k : {1, 3, 4, 5, 7, 8}) EXPECT_NEAR(p.coefficients[k][c], 0.0, 0.01 * (c + 1)) << k;
  }
  CueLight light;
  light.kind = CueLight::Kind::kEnvironment;
  light.environment = MapOf([](const Eigen::Vector3d& d) { return 1.0 + d.z(); });
  const ShLight sh = ShLight::FromCueLight(light);
  float out[kShLightChannelCount];
  sh.PixelFeatures({0, 0, 0}, {0, 0, 1}, out);
  EXPECT_NEAR(out[kShCoefficientCount + 2], std::sqrt(3 / (4 * kPi)) / 3, 1e-3);  // normalised Y10 part
  EXPECT_NEAR(out[2 * kShCoefficientCount + 2], 3 * 4 * kPi, 0.1);                // level B = int L_B
}

TEST(ShEncoding, PointAndDirectionalFeatures) {
  const CueLight point = CueLight::Point({0.3, 0.0, 0.4}, 2.0);  // 0.5 m from the origin
  float out[kShLightChannelCount];
  ShLight::FromCueLight(point).PixelFeatures({0, 0, 0}, {0, 0, 2}, out);
  const auto view = ShBasis({0, 0, 1});
  const auto to_light = ShBasis(Eigen::Vector3d(0.6, 0, 0.8));
  for (int k = 0; k < kShCoefficientCount; ++k) {
    EXPECT_NEAR(out[k], view[k], 1e-6);
    EXPECT_NEAR(out[kShCoefficientCount + k], to_light[k], 1e-6);
  }
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(out[2 * kShCoefficientCount + c], 2.0 / 0.25, 1e-5);  // I / r^2

  CueLight sun;
  sun.kind = CueLight::Kind::kDirectional;
  sun.direction_to_light = {0, 3, 4};
  sun.color = {1, 2, 3};
  ShLight::FromCueLight(sun).PixelFeatures({5, 5, 5}, {0, 0, 2}, out);
  const auto dir = ShBasis(Eigen::Vector3d(0, 0.6, 0.8));
  for (int k = 0; k < kShCoefficientCount; ++k) EXPECT_NEAR(out[kShCoefficientCount + k], dir[k], 1e-6);
  EXPECT_NEAR(out[2 * kShCoefficientCount + 2], 3.0, 1e-6);  // no falloff

  CueLight area;
  area.kind = CueLight::Kind::kQuad;
  EXPECT_THROW(ShLight::FromCueLight(area), Error);
}

TEST(CueFormat, ChannelsAndChecks) {
  EXPECT_EQ(CueFormat{}.Channels(), CueFrameChannels());
  EXPECT_EQ(CueFormat{}.light_channels(), kCueChannelCount);
  const CueFormat one{CueFormat::kRadiance, {"lambert"}};
  EXPECT_EQ(one.light_channels(), 3);
  EXPECT_EQ(one.Channels().size(), 3u + kGeometryChannelCount);
  const CueFormat sh{CueFormat::kSh, CueFormat::DefaultBasisNames()};
  EXPECT_EQ(sh.light_channels(), kShLightChannelCount);
  EXPECT_EQ(sh.Channels().front(), "shv0");
  EXPECT_THROW((CueFormat{"cue", {"lambert"}}.Check()), Error);
  EXPECT_THROW((CueFormat{CueFormat::kRadiance, {"ggx_0.5"}}.Check()), Error);
  EXPECT_THROW((CueFormat{CueFormat::kRadiance, {"lambert", "lambert"}}.Check()), Error);
  EXPECT_THROW((CueFormat{CueFormat::kRadiance, {}}.Check()), Error);
  EXPECT_EQ(CueFormat::FromJson(one.ToJson(), "test"), one);
  EXPECT_EQ(CueFormat::FromJson(nlohmann::json::object(), "test"), CueFormat{});
  EXPECT_NE(one, CueFormat{});
}

}  // namespace
}  // namespace relit::relight
