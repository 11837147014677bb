// Coverage statistics and warnings against captures with known geometry:
// flash on the camera, two phones in lockstep, independent phones, a narrow
// cone of views.
#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"
#include "report/coverage.h"

namespace relit::report {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d Direction(double elevation_deg, double azimuth_deg) {
  const double e = elevation_deg * kPi / 180, a = azimuth_deg * kPi / 180;
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

bool HasWarning(const CoverageStats& s, const std::string& part) {
  for (const std::string& w : s.warnings) {
    if (w.find(part) != std::string::npos) return true;
  }
  return false;
}

TEST(Coverage, AngularSpreadKnownAnswers) {
  EXPECT_DOUBLE_EQ(AngularSpreadDeg({}), 0);
  EXPECT_NEAR(AngularSpreadDeg({{0, 0, 2}}), 0, 1e-6);
  EXPECT_NEAR(AngularSpreadDeg({Direction(60, 0), Direction(60, 180)}), 30, 1e-9);
  // A ring at 30 deg elevation: resultant sin(30) = 0.5 -> 60 deg.
  std::vector<Eigen::Vector3d> ring;
  for (int k = 0; k < 36; ++k) ring.push_back(Direction(30, k * 10));
  EXPECT_NEAR(AngularSpreadDeg(ring), 60, 1e-9);
  // Uniform on the hemisphere (Fibonacci points): mean z = 1/2 -> 60 deg.
  std::vector<Eigen::Vector3d> uniform;
  const int n = 4000;
  for (int i = 0; i < n; ++i) {
    const double z = (i + 0.5) / n;
    const double a = i * kPi * (3 - std::sqrt(5.0));
    const double r = std::sqrt(1 - z * z);
    uniform.push_back({r * std::cos(a), r * std::sin(a), z});
  }
  EXPECT_NEAR(AngularSpreadDeg(uniform), 60, 0.1);
}

TEST(Coverage, LightInViewFrameAndCells) {
  const Eigen::Vector3d l = LightInViewFrame({2, 0, 0}, {0, 0, 3});
  EXPECT_NEAR((l - Eigen::Vector3d(0, 1, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((LightInViewFrame({0, 0, 1}, {0, 0, 1}) - Eigen::Vector3d(0, 0, 1)).norm(), 0, 1e-12);
  // Rotating both about world Z leaves the relative direction unchanged.
  const Eigen::Vector3d a = LightInViewFrame(Direction(20, 10), Direction(50, 70));
  const Eigen::Vector3d b = LightInViewFrame(Direction(20, 130), Direction(50, 190));
  EXPECT_NEAR((a - b).norm(), 0, 1e-12);
  EXPECT_EQ(HemisphereCell(Direction(1, 0)), 0);
  EXPECT_EQ(HemisphereCell(Direction(45, 100)), 8 + 2);
  EXPECT_EQ(HemisphereCell({0, 0, 1}), 16);
  EXPECT_EQ(HemisphereCell(Direction(-20, 359)), 7);
}

TEST(Coverage, FlashOnTheCameraIsFlagged) {
  std::vector<Eigen::Vector3d> views, lights;
  for (int k = 0; k < 40; ++k) {
    views.push_back(0.5 * Direction(20 + k, k * 9));
    lights.push_back(0.5 * Direction(20 + k, k * 9) + Eigen::Vector3d(0.01, 0, 0));  // 1 cm from the lens
  }
  const CoverageStats s = ComputeCoverage(views, lights, CoverageThresholds{});
  EXPECT_LT(s.median_view_light_angle_deg, 2.0);
  EXPECT_TRUE(HasWarning(s, "next to the camera"));
  EXPECT_FALSE(HasWarning(s, "camera directions cover a narrow cone"));
  EXPECT_FALSE(HasWarning(s, "light directions cover a narrow cone"));
}

TEST(Coverage, PhonesInLockstepAreCorrelated) {
  std::vector<Eigen::Vector3d> views, lights;
  for (int k = 0; k < 36; ++k) {
    views.push_back(Direction(30, k * 10));
    lights.push_back(Direction(30, k * 10 + 60));  // always 60 deg ahead
  }
  const CoverageStats s = ComputeCoverage(views, lights, CoverageThresholds{});
  EXPECT_NEAR(s.view_spread_deg, 60, 1e-9);
  EXPECT_NEAR(s.light_spread_deg, 60, 1e-9);
  EXPECT_NEAR(s.relative_light_spread_deg, 0, 1e-5);
  EXPECT_GT(s.median_view_light_angle_deg, 40);
  EXPECT_TRUE(HasWarning(s, "strongly correlated"));
  EXPECT_FALSE(HasWarning(s, "next to the camera"));
  EXPECT_EQ(s.view_cells, 8);
  EXPECT_EQ(s.frames, 36);
}

TEST(Coverage, IndependentPhonesPass) {
  std::vector<Eigen::Vector3d> views, lights;
  for (int k = 0; k < 60; ++k) {
    views.push_back(Direction(15 + 50 * (k % 5) / 4.0, k * 6));           // half a turn per 30 frames
    lights.push_back(Direction(20 + 55 * ((k * 7) % 11) / 10.0, -k * 17));  // other way round, other heights
  }
  const CoverageStats s = ComputeCoverage(views, lights, CoverageThresholds{});
  EXPECT_TRUE(s.warnings.empty()) << s.warnings.front();
  EXPECT_GT(s.relative_light_spread_deg, 30);
  EXPECT_GT(s.view_light_cell_pairs, 30);
}

TEST(Coverage, NarrowConeOfViewsIsFlagged) {
  std::vector<Eigen::Vector3d> views, lights;
  for (int k = 0; k < 20; ++k) {
    views.push_back(Direction(40 + (k % 3), 10 + k * 0.25));
    lights.push_back(Direction(20 + 3 * k, k * 18));
  }
  const CoverageStats s = ComputeCoverage(views, lights, CoverageThresholds{});
  EXPECT_LT(s.view_spread_deg, 5);
  EXPECT_TRUE(HasWarning(s, "camera directions cover a narrow cone"));
  EXPECT_FALSE(HasWarning(s, "light directions cover a narrow cone"));
  EXPECT_TRUE(ComputeCoverage({}, {}, CoverageThresholds{}).warnings.size() == 1);
  EXPECT_THROW(ComputeCoverage(views, {}, CoverageThresholds{}), Error);
}

}  // namespace
}  // namespace relit::report
