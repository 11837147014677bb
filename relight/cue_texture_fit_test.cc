#include "relight/cue_texture_fit.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace relit::relight {
namespace {

// A smooth ground-truth weight field: the Lambert weight varies across the
// atlas, the GGX weights are constant per channel.
float TrueWeight(int k, int c, float u, float v) {
  if (k == 0) return 0.4f + 0.1f * c + 0.2f * std::sin(6.0f * u) * std::cos(4.0f * v);
  return 0.05f * k + 0.02f * c;
}

struct Pixel {
  float cues[15];
  float u, v;
  float rgb[3];
};

Pixel RandomPixel(std::mt19937& rng, float u_max = 1.0f) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  Pixel p;
  p.u = u_max * unit(rng);
  p.v = unit(rng);
  for (int k = 0; k < 5; ++k) {
    const float shade = unit(rng) * (k == 0 ? 1.0f : 2.0f);
    for (int c = 0; c < 3; ++c) p.cues[3 * k + c] = shade;
  }
  for (int c = 0; c < 3; ++c) {
    p.rgb[c] = 0;
    for (int k = 0; k < 5; ++k) p.rgb[c] += TrueWeight(k, c, p.u, p.v) * p.cues[3 * k + c];
  }
  return p;
}

TEST(CueTextureFitTest, RecoversASmoothLinearCueModel) {
  CueFitOptions options;
  options.iterations_per_level = 200;
  CueTextureFit fit(32, options);
  std::mt19937 rng(3);
  for (int i = 0; i < 40000; ++i) {
    const Pixel p = RandomPixel(rng);
    fit.AddPixel(p.cues, p.u, p.v, p.rgb);
  }
  const CueFitStats stats = fit.Solve();
  EXPECT_EQ(stats.pixels, 40000);
  EXPECT_EQ(stats.texels_seen, 32 * 32);
  EXPECT_LT(stats.rms_residual, 0.01);
  // Held-out pixels: the bilinear weights predict them.
  double sq = 0, ref = 0;
  for (int i = 0; i < 2000; ++i) {
    const Pixel p = RandomPixel(rng);
    const auto w = fit.WeightsAt(p.u, p.v);
    for (int c = 0; c < 3; ++c) {
      double pred = 0;
      for (int k = 0; k < 5; ++k) pred += w[3 * k + c] * p.cues[3 * k + c];
      sq += (pred - p.rgb[c]) * (pred - p.rgb[c]);
      ref += p.rgb[c] * p.rgb[c];
    }
  }
  EXPECT_LT(std::sqrt(sq / ref), 0.01);
  // The Lambert weight itself, in the middle of the atlas.
  EXPECT_NEAR(fit.WeightsAt(0.5f, 0.5f)[0], TrueWeight(0, 0, 0.5f, 0.5f), 0.02);
}

TEST(CueTextureFitTest, TexelsWithoutPixelsContinueTheirNeighbours) {
  CueTextureFit fit(16, CueFitOptions{});
  std::mt19937 rng(5);
  for (int i = 0; i < 20000; ++i) {
    const Pixel p = RandomPixel(rng, 0.5f);  // only the left half of the atlas is seen
    fit.AddPixel(p.cues, p.u, p.v, p.rgb);
  }
  const CueFitStats stats = fit.Solve();
  EXPECT_LE(stats.texels_seen, 16 * 9);
  // Just right of the seen half, the weights continue the seen ones.
  for (float v : {0.2f, 0.5f, 0.8f}) {
    const auto seen = fit.WeightsAt(0.45f, v), unseen = fit.WeightsAt(0.6f, v);
    for (int j = 0; j < 15; ++j) EXPECT_NEAR(unseen[j], seen[j], 0.1) << "weight " << j << " at v " << v;
  }
}

TEST(CueTextureFitTest, KeepsAnEvenSubsetAboveThePixelBudget) {
  CueFitOptions options;
  options.max_pixels = 1000;
  CueTextureFit fit(8, options);
  std::mt19937 rng(7);
  for (int i = 0; i < 5000; ++i) {
    const Pixel p = RandomPixel(rng);
    fit.AddPixel(p.cues, p.u, p.v, p.rgb);
  }
  EXPECT_GE(fit.pixels(), 1000);
  EXPECT_LT(fit.pixels(), 2000);
  EXPECT_LT(fit.Solve().rms_residual, 0.05);
}

TEST(CueTextureFitTest, RefusesBadOptionsAndEmptyFits) {
  CueFitOptions bad;
  bad.ridge = 0;
  EXPECT_ANY_THROW(CueTextureFit(8, bad));
  CueTextureFit empty(8, CueFitOptions{});
  EXPECT_ANY_THROW(empty.Solve());
  EXPECT_ANY_THROW(empty.WeightsAt(0.5f, 0.5f));
}

}  // namespace
}  // namespace relit::relight
