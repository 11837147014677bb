#include "relight/cue_texture_fit.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>

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

// RMS error of the fit's prediction of 2000 new pixels, relative to their RMS.
double HeldOutRelativeError(const CueTextureFit& fit, std::mt19937& rng) {
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
  return std::sqrt(sq / ref);
}

TEST(CueTextureFitTest, RecoversASmoothLinearCueModel) {
  CueFitOptions options;
  options.iterations_per_level = 200;
  options.saturation_level = 0;  // targets above 1 here are not clipped
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
  EXPECT_LT(HeldOutRelativeError(fit, rng), 0.01);
  // The Lambert weight itself, in the middle of the atlas.
  EXPECT_NEAR(fit.WeightsAt(0.5f, 0.5f)[0], TrueWeight(0, 0, 0.5f, 0.5f), 0.02);
}

// One pixel in eight is far brighter than any cue weights explain (a glint,
// the board mirrored by glossy paint): least squares lifts every texel they
// land on, the robust rounds weigh them down and recover the true weights.
TEST(CueTextureFitTest, RobustRoundsIgnorePixelsNoWeightsExplain) {
  auto held_out_error = [](int robust_rounds, CueFitStats* stats) {
    CueFitOptions options;
    options.saturation_level = 0;
    options.iterations_per_level = 200;
    options.robust_rounds = robust_rounds;
    CueTextureFit fit(16, options);
    std::mt19937 rng(11);
    for (int i = 0; i < 40000; ++i) {
      Pixel p = RandomPixel(rng);
      if (i % 8 == 0) {
        for (float& c : p.rgb) c += 1.5f;
      }
      fit.AddPixel(p.cues, p.u, p.v, p.rgb);
    }
    *stats = fit.Solve();
    return HeldOutRelativeError(fit, rng);
  };
  CueFitStats plain, robust;
  const double plain_error = held_out_error(0, &plain);
  const double robust_error = held_out_error(2, &robust);
  EXPECT_GT(plain_error, 0.1);  // least squares follows the outliers
  EXPECT_LT(robust_error, 0.3 * plain_error);
  EXPECT_EQ(plain.robust_sigma, 0);
  EXPECT_GT(robust.robust_sigma, 0);
  // The outliers (1 in 8) are weighed down.
  EXPECT_GT(robust.robust_downweighted, 0.11);
}

TEST(CueTextureFitTest, TexelsWithoutPixelsContinueTheirNeighbours) {
  CueFitOptions options;
  options.saturation_level = 0;
  CueTextureFit fit(16, options);
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
  options.saturation_level = 0;
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

// Frames whose photos are displaced against their cue frames by known
// sub-pixel shifts (a pose error): the alignment finds the shifts (up to
// their common mean, which no data can tell) and the fit gets sharper.
TEST(CueTextureFitTest, AlignmentRecoversEachFramesShift) {
  constexpr int kSize = 48;
  const std::vector<std::array<double, 2>> truth = {{0.0, 0.0}, {0.7, -0.4}, {-0.5, 0.9}, {1.2, 0.3}, {-0.8, -0.9}};
  auto albedo = [](double u, double v) {
    return 0.5 + 0.4 * std::sin(2 * M_PI * 2.5 * u) * std::sin(2 * M_PI * 2.0 * v);
  };
  auto fit_with = [&](int rounds, std::vector<std::array<double, 2>>* shifts) {
    CueFitOptions options;
    options.align_rounds = rounds;
    options.smoothness_diffuse = 0.01;
    CueTextureFit fit(32, options);
    for (size_t i = 0; i < truth.size(); ++i) {
      const size_t n = kSize * kSize;
      std::vector<float> cues(n * 15, 0.0f), uv(n * 2), coverage(n), target(n * 3), matte(n, 1.0f);
      // Shading that differs per frame; the photo is the model moved by truth[i].
      auto shading = [&](double x, double y) { return 0.6 + 0.4 * std::cos(0.05 * (i + 1) * x + 0.03 * y); };
      for (int y = 0; y < kSize; ++y) {
        for (int x = 0; x < kSize; ++x) {
          const size_t o = static_cast<size_t>(y) * kSize + x;
          const double u = (x + 0.5) / kSize, v = 1.0 - (y + 0.5) / kSize;
          uv[2 * o] = static_cast<float>(u);
          uv[2 * o + 1] = static_cast<float>(v);
          coverage[o] = std::hypot(x - 23.5, y - 23.5) < 20 ? 1.0f : 0.0f;
          for (int c = 0; c < 3; ++c) cues[o * 15 + c] = static_cast<float>(shading(x, y));
          const double xs = x - truth[i][0], ys = y - truth[i][1];
          const double value = albedo((xs + 0.5) / kSize, 1.0 - (ys + 0.5) / kSize) * shading(xs, ys);
          for (int c = 0; c < 3; ++c) target[3 * o + c] = static_cast<float>(value);
        }
      }
      fit.AddFrame({kSize, kSize, cues.data(), uv.data(), coverage.data(), target.data(), matte.data()});
    }
    const CueFitStats stats = fit.Solve();
    shifts->clear();
    for (size_t i = 0; i < truth.size(); ++i) shifts->push_back(fit.FrameShift(static_cast<int>(i)));
    return stats;
  };
  std::vector<std::array<double, 2>> found, none;
  const CueFitStats aligned = fit_with(3, &found);
  const CueFitStats unaligned = fit_with(0, &none);
  std::printf("rms residual: aligned %.4f, unaligned %.4f; median shift %.2f px\n", aligned.rms_residual,
              unaligned.rms_residual, aligned.median_shift_px);
  std::array<double, 2> mean_error{0, 0};
  for (size_t i = 0; i < truth.size(); ++i) {
    for (int a = 0; a < 2; ++a) mean_error[a] += (found[i][a] - truth[i][a]) / truth.size();
  }
  for (size_t i = 0; i < truth.size(); ++i) {
    for (int a = 0; a < 2; ++a) {
      EXPECT_NEAR(found[i][a] - mean_error[a], truth[i][a], 0.15) << "frame " << i << " axis " << a;
      EXPECT_EQ(none[i][a], 0.0);
    }
  }
  EXPECT_LT(aligned.rms_residual, 0.5 * unaligned.rms_residual);
}

// A clipped channel only bounds the radiance from below. A red surface
// (albedo 0.8, 0.35, 0.35) seen under a Lambert cue of 1 and of 2: under 2
// its red reads 1 (clipped from 1.6). Fitted as equal, the clipped pixels
// pull red down to ~0.6; fitted one-sided, red stays 0.8 and green, never
// clipped, is untouched.
TEST(CueTextureFitTest, FitsClippedChannelsOneSided) {
  auto fit_red = [](double saturation_level, CueFitStats* stats) {
    CueFitOptions options;
    options.saturation_level = saturation_level;
    CueTextureFit fit(4, options);
    const float dim[15] = {1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    const float bright[15] = {2, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    const float dim_rgb[3] = {0.8f, 0.35f, 0.35f}, clipped_rgb[3] = {1.0f, 0.7f, 0.7f};
    for (int i = 0; i < 100; ++i) {
      if (i % 2) {
        fit.AddPixel(dim, 0.5f, 0.5f, dim_rgb);
      } else {
        fit.AddPixel(bright, 0.5f, 0.5f, clipped_rgb);
      }
    }
    *stats = fit.Solve();
    return fit.WeightsAt(0.5f, 0.5f);
  };
  CueFitStats one_sided, equal;
  const std::array<float, 15> w = fit_red(0.9, &one_sided);
  const std::array<float, 15> w_equal = fit_red(0, &equal);
  EXPECT_EQ(one_sided.pixels, 100);
  EXPECT_EQ(one_sided.saturated_pixels, 50);
  EXPECT_EQ(one_sided.saturated_above, 50);  // 2 x 0.8 = 1.6 > 1
  EXPECT_NEAR(w[0], 0.8, 0.01);
  EXPECT_NEAR(w[1], 0.35, 0.01);
  EXPECT_LT(one_sided.rms_residual, 0.01);
  EXPECT_EQ(equal.saturated_pixels, 0);
  EXPECT_NEAR(w_equal[0], 0.56, 0.02);  // (0.8 + 2 x 1) / (1 + 4)
  EXPECT_NEAR(w_equal[1], 0.35, 0.01);
}

// A clipped pixel the fit predicts below its reading stays an equality.
TEST(CueTextureFitTest, ClippedPixelsStillPullUp) {
  CueFitOptions options;
  options.saturation_level = 0.9;
  options.clip_model = "lift";
  CueTextureFit fit(4, options);
  const float cues[15] = {1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  const float dark[3] = {0.5f, 0.5f, 0.5f}, clipped[3] = {0.95f, 0.95f, 0.95f};
  for (int i = 0; i < 100; ++i) fit.AddPixel(cues, 0.5f, 0.5f, i % 4 ? dark : clipped);
  const CueFitStats stats = fit.Solve();
  EXPECT_EQ(stats.saturated_above, 0);
  EXPECT_NEAR(fit.WeightsAt(0.5f, 0.5f)[0], 0.25 * 0.95 + 0.75 * 0.5, 0.01);
}

// A channel clipped in every frame that sees it is only bounded below, and
// the one-sided fit leaves it at its reading: a pink surface (0.8, 0.4,
// 0.4) lit only by a cue of 1.5 reads red 1 (1.2 clipped), so red rests
// at 1 / 1.5 = 0.67. A white surface (0.6) seen under cues of 1 and 2 pins
// its own clipped readings 1.2x above the clip; auto lifts every clipped
// reading by that median overshoot, and the pink's red comes back to 0.8.
TEST(CueTextureFitTest, ClippedReadingsAreLiftedByTheOvershootTheFitSees) {
  auto fit_pink = [](double clip_overshoot, CueFitStats* stats) {
    CueFitOptions options;
    options.saturation_level = 0.9;
    options.clip_model = "lift";
    options.clip_overshoot = clip_overshoot;
    CueTextureFit fit(4, options);
    auto lambert = [](float e) { return std::array<float, 15>{e, e, e, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}; };
    const std::array<float, 15> one = lambert(1), two = lambert(2), one_and_half = lambert(1.5f);
    const float white_dim[3] = {0.6f, 0.6f, 0.6f}, white_clipped[3] = {1, 1, 1}, pink_clipped[3] = {1, 0.6f, 0.6f};
    for (int i = 0; i < 60; ++i) {
      fit.AddPixel(i % 2 ? one.data() : two.data(), 0.125f, 0.5f, i % 2 ? white_dim : white_clipped);
      fit.AddPixel(one_and_half.data(), 0.875f, 0.5f, pink_clipped);
    }
    *stats = fit.Solve();
    return std::make_pair(fit.WeightsAt(0.125f, 0.5f), fit.WeightsAt(0.875f, 0.5f));
  };
  CueFitStats lifted, reading;
  const auto [white, pink] = fit_pink(CueFitOptions::kAutoClipOvershoot, &lifted);
  const auto [white_at_reading, pink_at_reading] = fit_pink(1.0, &reading);
  EXPECT_NEAR(lifted.clip_overshoot, 1.2, 0.02);
  EXPECT_EQ(reading.clip_overshoot, 1.0);
  EXPECT_NEAR(pink_at_reading[0], 1.0 / 1.5, 0.02);  // red short
  EXPECT_NEAR(pink[0], 0.8, 0.03);
  EXPECT_NEAR(pink[1], 0.4, 0.01);
  EXPECT_NEAR(white[0], 0.6, 0.01);
  EXPECT_NEAR(white_at_reading[0], 0.6, 0.01);
  CueFitOptions bad;
  bad.clip_overshoot = 0.5;
  EXPECT_ANY_THROW(CheckOptions(bad));
}

// Noise decides which bright pixels clip: of a surface whose radiance
// straddles white, the pixels that stay below it are those whose noise was
// negative, and a fit of them (with the clipped ones as bounds at their
// readings) sits low. A white-ish surface (albedo 0.8, 0.5, 0.5) under
// Lambert cues 0.5-1.5, 15 % multiplicative noise, clipped at white (1,
// the saturation level): the censored model finds the red albedo, the
// bounds at the readings do not, and the noise is measured.
TEST(CueTextureFitTest, CensoredModelUndoesTheNoiseBiasOfBrightPixels) {
  auto fit_red = [](const std::string& clip_model, CueFitStats* stats) {
    CueFitOptions options;
    options.saturation_level = 0.999;
    options.clip_model = clip_model;
    options.clip_overshoot = 1.0;
    CueTextureFit fit(4, options);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> shade(0.5f, 1.5f);
    std::normal_distribution<float> noise(0.0f, 0.15f);
    const float albedo[3] = {0.8f, 0.5f, 0.5f};
    for (int i = 0; i < 8000; ++i) {
      const float e = shade(rng);
      const float cues[15] = {e, e, e, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
      float rgb[3];
      for (int c = 0; c < 3; ++c) rgb[c] = std::min(1.0f, albedo[c] * e * (1.0f + noise(rng)));
      fit.AddPixel(cues, 0.5f, 0.5f, rgb);
    }
    *stats = fit.Solve();
    return fit.WeightsAt(0.5f, 0.5f);
  };
  CueFitStats censored_stats, bound_stats;
  const std::array<float, 15> censored = fit_red("censored", &censored_stats);
  const std::array<float, 15> bound = fit_red("lift", &bound_stats);
  std::printf("red albedo 0.8: censored %.4f, bounds at the readings %.4f; noise %.3f, mean lift %.3f\n",
              censored[0], bound[0], censored_stats.clip_noise, censored_stats.clip_mean_lift);
  EXPECT_NEAR(censored[0], 0.8, 0.01);
  EXPECT_LT(bound[0], 0.785);  // the bias the censored model removes
  EXPECT_NEAR(censored[1], 0.5, 0.01);
  EXPECT_NEAR(censored_stats.clip_noise, 0.15, 0.02);
  EXPECT_GT(censored_stats.clip_mean_lift, 1.0);
  EXPECT_EQ(bound_stats.clip_noise, 0.0);
  CueFitOptions bad;
  bad.clip_model = "tobit";
  EXPECT_ANY_THROW(CheckOptions(bad));
}

// Auto: clipped pixels only in SDR video; an explicit level always wins.
TEST(CueTextureFitTest, ResolvesTheAutoSaturationLevelFromTheCapture) {
  EXPECT_EQ(ResolveSaturationLevel(-1, "srgb"), CueFitOptions::kSdrSaturationLevel);
  EXPECT_EQ(ResolveSaturationLevel(-1, "gamma2.2"), CueFitOptions::kSdrSaturationLevel);
  EXPECT_EQ(ResolveSaturationLevel(-1, "hlg"), 0.0);
  EXPECT_EQ(ResolveSaturationLevel(-1, "pq"), 0.0);
  EXPECT_EQ(ResolveSaturationLevel(-1, ""), 0.0);
  EXPECT_EQ(ResolveSaturationLevel(0.5, "srgb"), 0.5);
  EXPECT_EQ(ResolveSaturationLevel(0, "srgb"), 0.0);
  CueFitOptions bad;
  bad.saturation_level = -0.5;
  EXPECT_ANY_THROW(CheckOptions(bad));
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
