#include "core/render/envmaps.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "core/render/light.h"

namespace relit::render {
namespace {

// Luminance-weighted mean direction of a map: where its light comes from.
Eigen::Vector3d LightCentroid(const Image& map) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int y = 0; y < map.height(); ++y) {
    const double solid_angle = std::sin(M_PI * (y + 0.5) / map.height());
    for (int x = 0; x < map.width(); ++x) {
      const double luminance = 0.2126 * map.at(x, y, 0) + 0.7152 * map.at(x, y, 1) + 0.0722 * map.at(x, y, 2);
      sum += luminance * solid_angle * EnvironmentPixelDirection(x, y, map.width(), map.height());
    }
  }
  return sum;
}

TEST(AugmentationMaps, SixtyMapsAreValidDistinctAndDeterministic) {
  std::set<std::string> names;
  std::vector<Eigen::Vector3d> centroids;
  int kinds[3] = {0, 0, 0};
  for (int i = 0; i < 60; ++i) {
    const ProceduralEnvironment env = MakeAugmentationMap(64, 7, i);
    EXPECT_TRUE(names.insert(env.name).second) << env.name;
    ASSERT_EQ(env.map.width(), 64);
    ASSERT_EQ(env.map.height(), 32);
    float max_value = 0;
    for (float v : env.map.data()) {
      ASSERT_TRUE(std::isfinite(v) && v >= 0) << env.name;
      max_value = std::max(max_value, v);
    }
    EXPECT_GT(max_value, 0.5f) << env.name << " has no light brighter than its ambient";
    centroids.push_back(LightCentroid(env.map).normalized());
    kinds[env.name[1] == 'k' ? 0 : env.name[1] == 't' ? 1 : 2]++;
    // Importance sampling works on it (the augmentation samples directions).
    const EnvironmentLight light(env.map);
    float pdf = 0;
    const Vec3f d = light.Sample(Vec2f(0.3f, 0.6f), &pdf);
    EXPECT_GT(pdf, 0) << env.name;
    EXPECT_NEAR(d.norm(), 1.0f, 1e-4f);
  }
  EXPECT_EQ(kinds[0], 20);
  EXPECT_EQ(kinds[1], 20);
  EXPECT_EQ(kinds[2], 20);
  // Light comes from many directions across the family, not one.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : centroids) mean += c;
  EXPECT_LT((mean / centroids.size()).norm(), 0.8);
  const ProceduralEnvironment again = MakeAugmentationMap(64, 7, 13);
  EXPECT_EQ(again.map.data(), MakeAugmentationMap(64, 7, 13).map.data());
  EXPECT_NE(again.map.data(), MakeAugmentationMap(64, 8, 13).map.data());
}

TEST(AugmentationMaps, SkySunIsTheBrightestPixelAndAboveTheHorizon) {
  for (int i : {0, 3, 6, 9}) {
    const Image map = MakeAugmentationMap(128, 1, i).map;
    int best_y = 0;
    float best = -1;
    for (int y = 0; y < map.height(); ++y) {
      for (int x = 0; x < map.width(); ++x) {
        if (map.at(x, y, 1) > best) {
          best = map.at(x, y, 1);
          best_y = y;
        }
      }
    }
    EXPECT_LT(best_y, map.height() / 2) << "sky " << i;
  }
}

}  // namespace
}  // namespace relit::render
