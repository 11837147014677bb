#include "relight/partitions.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "core/error.h"
#include "core/options.h"

namespace relit::relight {
namespace {

// Uniform direction on the upper hemisphere (z >= 0).
Eigen::Vector3d RandomUpper(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d d(normal(rng), normal(rng), normal(rng));
  d.normalize();
  d.z() = std::abs(d.z());
  return d;
}

// Blend as a dense weight vector over all partitions.
Eigen::VectorXd Dense(const PartitionLayout& layout, const Eigen::Vector3d& d) {
  const PartitionBlend blend = layout.Blend(d);
  Eigen::VectorXd w = Eigen::VectorXd::Zero(layout.partition_count());
  for (int c = 0; c < blend.count; ++c) w[blend.partition[c]] += blend.weight[c];
  return w;
}

void ExpectValidBlends(const PartitionLayout& layout, int samples, uint64_t seed) {
  std::mt19937_64 rng(seed);
  for (int s = 0; s < samples; ++s) {
    const Eigen::Vector3d d = RandomUpper(rng);
    const PartitionBlend blend = layout.Blend(d);
    ASSERT_GE(blend.count, 2);
    double sum = 0;
    Eigen::Vector3d mix = Eigen::Vector3d::Zero();
    for (int c = 0; c < blend.count; ++c) {
      ASSERT_GE(blend.weight[c], 0.0);
      sum += blend.weight[c];
      mix += blend.weight[c] * layout.vertices()[blend.partition[c]];
    }
    ASSERT_NEAR(sum, 1.0, 1e-12);
    const std::vector<int> parts = layout.PartitionsOf(d);
    ASSERT_FALSE(parts.empty());
    for (int c = 0; c < blend.count; ++c) {
      if (blend.weight[c] > 1e-9) {
        EXPECT_NE(std::find(parts.begin(), parts.end(), blend.partition[c]), parts.end());
      }
    }
    if (blend.count == 3) {
      // Inside a real triangle the weights reproduce the direction's ray.
      EXPECT_LT(mix.normalized().cross(d).norm(), 1e-9) << d.transpose();
    }
  }
}

TEST(PartitionsTest, Dnl13HasThirteenVerticesAndEighteenTriangles) {
  const PartitionLayout layout = PartitionLayout::Dnl13();
  EXPECT_EQ(layout.partition_count(), 13);
  ASSERT_EQ(layout.triangles().size(), 18u);
  std::vector<int> degree(13, 0);
  for (const auto& t : layout.triangles()) {
    const auto& v = layout.vertices();
    const Eigen::Vector3d n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
    EXPECT_GT(n.dot(v[t[0]]), 0.0) << "triangle not counter-clockwise from outside";
    for (int i : t) ++degree[i];
  }
  EXPECT_EQ(degree[0], 6);  // zenith: fan over the 30-degree ring
  for (int i = 1; i < 7; ++i) EXPECT_EQ(degree[i], 5) << i;  // 2 zenith + 3 ring-horizon
  for (int i = 7; i < 13; ++i) EXPECT_EQ(degree[i], 3) << i;
}

TEST(PartitionsTest, Dnl13CoversTheUpperHemisphere) {
  ExpectValidBlends(PartitionLayout::Dnl13(), 20000, 1);
}

TEST(PartitionsTest, WeightIsOneAtEachVertex) {
  const PartitionLayout layout = PartitionLayout::Dnl13();
  for (int i = 0; i < layout.partition_count(); ++i) {
    const Eigen::VectorXd w = Dense(layout, layout.vertices()[i]);
    EXPECT_NEAR(w[i], 1.0, 1e-12) << i;
  }
}

TEST(PartitionsTest, WeightsAreContinuousAcrossTriangleEdges) {
  const PartitionLayout layout = PartitionLayout::Dnl13();
  const auto& v = layout.vertices();
  for (const auto& t : layout.triangles()) {
    for (int e = 0; e < 3; ++e) {
      const Eigen::Vector3d a = v[t[e]], b = v[t[(e + 1) % 3]];
      const Eigen::Vector3d normal = a.cross(b).normalized();
      for (double s : {0.1, 0.37, 0.5, 0.81}) {
        const Eigen::Vector3d p = ((1 - s) * a + s * b).normalized();
        const Eigen::VectorXd left = Dense(layout, (p + 1e-7 * normal).normalized());
        const Eigen::VectorXd right = Dense(layout, (p - 1e-7 * normal).normalized());
        EXPECT_LT((left - right).cwiseAbs().maxCoeff(), 1e-5) << "edge " << t[e] << "-" << t[(e + 1) % 3];
      }
    }
  }
  // Random nearby pairs anywhere (including across the horizon).
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal;
  for (int s = 0; s < 5000; ++s) {
    Eigen::Vector3d d(normal(rng), normal(rng), 0.3 * normal(rng));
    d.normalize();
    const Eigen::Vector3d jitter = 1e-7 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const double change = (Dense(layout, d) - Dense(layout, (d + jitter).normalized())).cwiseAbs().maxCoeff();
    ASSERT_LT(change, 1e-4) << d.transpose();
  }
}

TEST(PartitionsTest, BelowTheHorizonClampsOntoIt) {
  const PartitionLayout layout = PartitionLayout::Dnl13();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> azimuth(0, 2 * M_PI), below(-1.4, -0.01);
  for (int s = 0; s < 500; ++s) {
    const double az = azimuth(rng), el = below(rng);
    const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    const Eigen::Vector3d horizon(std::cos(az), std::sin(az), 0.0);
    EXPECT_LT((Dense(layout, d) - Dense(layout, horizon)).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_FALSE(layout.PartitionsOf(d).empty());
  }
  // Straight down: still a valid (split) blend.
  const PartitionBlend down = layout.Blend({0, 0, -1});
  EXPECT_NEAR(down.weight[0] + down.weight[1] + down.weight[2], 1.0, 1e-12);
}

TEST(PartitionsTest, FramesGoToTheVerticesOfTheirTriangle) {
  const PartitionLayout layout = PartitionLayout::Dnl13();
  std::mt19937_64 rng(5);
  std::vector<Eigen::Vector3d> directions;
  for (int i = 0; i < 3000; ++i) directions.push_back(RandomUpper(rng));
  directions.push_back({0, 0, 1});
  const auto frames = layout.AssignFrames(directions);
  ASSERT_EQ(frames.size(), 13u);
  std::vector<int> count(directions.size(), 0);
  for (const auto& list : frames) {
    EXPECT_FALSE(list.empty());
    for (int f : list) ++count[f];
  }
  for (size_t f = 0; f < directions.size(); ++f) EXPECT_EQ(count[f], 3) << f;
  // The zenith frame is in the zenith partition; one near a horizon vertex
  // is in that vertex's partition.
  EXPECT_EQ(frames[0].back(), static_cast<int>(directions.size()) - 1);
  const std::vector<int> near7 = layout.PartitionsOf(DirectionFromElevationAzimuthDeg(2.0, 31.0));
  EXPECT_NE(std::find(near7.begin(), near7.end(), 7), near7.end());
}

TEST(PartitionsTest, SingleLayoutHoldsEverything) {
  const PartitionLayout layout = PartitionLayout::Single();
  EXPECT_EQ(layout.partition_count(), 1);
  EXPECT_TRUE(layout.triangles().empty());
  const PartitionBlend blend = layout.Blend({1, 2, -3});
  EXPECT_EQ(blend.count, 1);
  EXPECT_EQ(blend.weight[0], 1.0);
  const auto frames = layout.AssignFrames({{1, 0, 0}, {0, 0, 1}});
  EXPECT_EQ(frames[0], (std::vector<int>{0, 1}));
}

TEST(PartitionsTest, CustomLayoutWithoutHorizonRingStillCoversEverything) {
  // Random vertices at 15..90 deg elevation: directions below the lowest
  // vertices fall in nadir faces and clamp onto the hull's lower edges.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> el(15, 90), az(0, 360);
  PartitionLayoutOptions options;
  options.layout = "custom";
  for (int i = 0; i < 25; ++i) {
    options.elevation_deg.push_back(el(rng));
    options.azimuth_deg.push_back(az(rng));
  }
  const PartitionLayout layout = PartitionLayout::FromOptions(options);
  EXPECT_EQ(layout.partition_count(), 25);
  EXPECT_GT(layout.triangles().size(), 20u);
  ExpectValidBlends(layout, 5000, 2);
  std::normal_distribution<double> normal;
  for (int s = 0; s < 3000; ++s) {
    const Eigen::Vector3d d = RandomUpper(rng);
    const Eigen::Vector3d jitter = 1e-7 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    ASSERT_LT((Dense(layout, d) - Dense(layout, (d + jitter).normalized())).cwiseAbs().maxCoeff(), 1e-4);
  }
}

TEST(PartitionsTest, RejectsDegenerateLayouts) {
  // Two vertices + the nadir are coplanar: no volume.
  EXPECT_THROW(PartitionLayout::FromVertices({{1, 0, 0}, {0, 0, 1}}), Error);
  // All on the horizon: the origin lies on the hull.
  EXPECT_THROW(PartitionLayout::FromVertices({{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}}), Error);
  EXPECT_THROW(PartitionLayout::FromVertices({{0, 0, 1}, {0, 0.001, 1}, {1, 0, 0}}), Error);
}

TEST(PartitionsTest, OptionsFromYaml) {
  OptionsReader reader = OptionsReader::FromString(
      "layout: custom\nelevation_deg: [90, 30, 30, 30]\nazimuth_deg: [0, 0, 120, 240]\n");
  PartitionLayoutOptions options;
  ReadOptions(reader, &options);
  CheckOptions(options);
  const PartitionLayout layout = PartitionLayout::FromOptions(options);
  EXPECT_EQ(layout.partition_count(), 4);
  ExpectValidBlends(layout, 2000, 4);
  OptionsReader bad = OptionsReader::FromString("layout: dnl12\n");
  PartitionLayoutOptions bad_options;
  EXPECT_THROW(ReadOptions(bad, &bad_options), Error);
  EXPECT_EQ(OptionsToJson(PartitionLayoutOptions()), nlohmann::json({{"layout", "dnl13"}}));
  EXPECT_EQ(OptionsToJson(options).at("azimuth_deg"), nlohmann::json({0.0, 0.0, 120.0, 240.0}));
}

}  // namespace
}  // namespace relit::relight
