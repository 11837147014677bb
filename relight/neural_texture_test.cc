#include "relight/neural_texture.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"

namespace relit::relight {
namespace {

// Direct loop-based reference of the documented filtering, in double.
struct ReferenceTexture {
  int channels, size;
  std::vector<std::vector<double>> levels;  // [level][(c * s + row) * s + col]

  ReferenceTexture(const torch::Tensor& level0, int level_count)
      : channels(static_cast<int>(level0.size(1))), size(static_cast<int>(level0.size(2))) {
    const auto t = level0.to(torch::kDouble).contiguous();
    levels.emplace_back(t.data_ptr<double>(), t.data_ptr<double>() + t.numel());
    for (int l = 1, s = size / 2; l < level_count; ++l, s /= 2) {
      const std::vector<double>& prev = levels.back();
      std::vector<double> next(static_cast<size_t>(channels) * s * s);
      for (int c = 0; c < channels; ++c) {
        for (int r = 0; r < s; ++r) {
          for (int q = 0; q < s; ++q) {
            auto at = [&](int rr, int qq) { return prev[(static_cast<size_t>(c) * 2 * s + rr) * 2 * s + qq]; };
            next[(static_cast<size_t>(c) * s + r) * s + q] =
                0.25 * (at(2 * r, 2 * q) + at(2 * r + 1, 2 * q) + at(2 * r, 2 * q + 1) + at(2 * r + 1, 2 * q + 1));
          }
        }
      }
      levels.push_back(std::move(next));
    }
  }

  // Bilinear, clamp to edge, texel centres at (i + 0.5) / s, v up.
  double Bilinear(int level, int c, double u, double v) const {
    const int s = size >> level;
    const double x = u * s - 0.5, y = (1.0 - v) * s - 0.5;
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double fx = x - x0, fy = y - y0;
    auto texel = [&](int row, int col) {
      row = std::clamp(row, 0, s - 1);
      col = std::clamp(col, 0, s - 1);
      return levels[level][(static_cast<size_t>(c) * s + row) * s + col];
    };
    return (1 - fy) * ((1 - fx) * texel(y0, x0) + fx * texel(y0, x0 + 1)) +
           fy * ((1 - fx) * texel(y0 + 1, x0) + fx * texel(y0 + 1, x0 + 1));
  }

  double Trilinear(int c, double u, double v, const double d[4]) const {
    const int level_count = static_cast<int>(levels.size());
    const double rho = std::max(std::hypot(d[0] * size, d[1] * size), std::hypot(d[2] * size, d[3] * size));
    const double lod = std::clamp(std::log2(rho), 0.0, level_count - 1.0);
    const int l0 = static_cast<int>(std::floor(lod));
    const int l1 = std::min(l0 + 1, level_count - 1);
    const double f = lod - l0;
    return (1 - f) * Bilinear(l0, c, u, v) + f * Bilinear(l1, c, u, v);
  }
};

NeuralTexture MakeTexture(int resolution, int channels_per_basis, uint64_t seed) {
  torch::manual_seed(seed);
  NeuralTextureOptions options;
  options.resolution_px = resolution;
  options.channels_per_basis = channels_per_basis;
  options.init_min = -1.0;
  options.init_max = 1.0;
  NeuralTexture texture(options);
  texture->to(torch::kDouble);
  return texture;
}

// Random uv (some outside [0, 1]) and derivatives spanning all levels.
void RandomQuery(int64_t b, int64_t h, int64_t w, torch::Tensor* uv, torch::Tensor* derivatives) {
  const auto opts = torch::TensorOptions().dtype(torch::kDouble);
  *uv = torch::rand({b, h, w, 2}, opts) * 1.4 - 0.2;
  const auto magnitude = torch::exp2(torch::rand({b, h, w, 1}, opts) * 9.0 - 7.0);  // 1/128 .. 4
  *derivatives = (torch::rand({b, h, w, 4}, opts) * 2.0 - 1.0) * magnitude;
}

TEST(NeuralTextureTest, MatchesLoopReference) {
  NeuralTexture texture = MakeTexture(16, 2, 3);
  torch::Tensor uv, derivatives;
  RandomQuery(2, 7, 9, &uv, &derivatives);
  auto coverage = torch::ones({2, 1, 7, 9}, torch::kDouble);
  coverage.index_put_({0, 0, 3, 4}, 0.0);
  coverage.index_put_({1, 0, 0, 0}, 0.25);
  const auto out = texture->forward(uv, derivatives, coverage).contiguous();
  ASSERT_EQ(out.sizes(), (std::vector<int64_t>{2, 10, 7, 9}));
  const ReferenceTexture reference(texture->texels().detach(), texture->options().levels());
  ASSERT_EQ(reference.levels.size(), 5u);
  const auto uv_a = uv.accessor<double, 4>();
  const auto d_a = derivatives.accessor<double, 4>();
  const auto out_a = out.accessor<double, 4>();
  const auto cov_a = coverage.accessor<double, 4>();
  double max_error = 0;
  for (int b = 0; b < 2; ++b) {
    for (int y = 0; y < 7; ++y) {
      for (int x = 0; x < 9; ++x) {
        const double d[4] = {d_a[b][y][x][0], d_a[b][y][x][1], d_a[b][y][x][2], d_a[b][y][x][3]};
        for (int c = 0; c < 10; ++c) {
          const double expected = cov_a[b][0][y][x] * reference.Trilinear(c, uv_a[b][y][x][0], uv_a[b][y][x][1], d);
          max_error = std::max(max_error, std::abs(out_a[b][c][y][x] - expected));
        }
      }
    }
  }
  EXPECT_LT(max_error, 1e-12);
}

TEST(NeuralTextureTest, VIsUpAndBordersClamp) {
  NeuralTexture texture = MakeTexture(8, 1, 4);
  const auto texels = texture->texels().detach();
  const double h = 1.0 / 16.0;  // half a texel of level 0
  // One pixel per query; tiny derivatives select level 0.
  auto sample = [&](double u, double v) {
    const auto uv = torch::tensor({u, v}, torch::kDouble).reshape({1, 1, 1, 2});
    const auto d = torch::full({1, 1, 1, 4}, 1e-6, torch::kDouble);
    return texture->forward(uv, d, torch::ones({1, 1, 1, 1}, torch::kDouble)).detach().flatten();
  };
  // Texel centres: top-left texel is (u, v) = (h, 1 - h).
  EXPECT_TRUE(torch::allclose(sample(h, 1 - h), texels.index({0, torch::indexing::Slice(), 0, 0})));
  EXPECT_TRUE(torch::allclose(sample(h, h), texels.index({0, torch::indexing::Slice(), 7, 0})));
  EXPECT_TRUE(torch::allclose(sample(1 - h, h), texels.index({0, torch::indexing::Slice(), 7, 7})));
  // Outside the atlas and in the outer half texel: the edge texels.
  EXPECT_TRUE(torch::allclose(sample(-0.7, 1.9), sample(h, 1 - h)));
  EXPECT_TRUE(torch::allclose(sample(0.0, 1.0), sample(h, 1 - h)));
  EXPECT_TRUE(torch::allclose(sample(1.4, -3.0), sample(1 - h, h)));
  // Along the left border only v matters.
  EXPECT_TRUE(torch::allclose(sample(-0.2, 0.4), sample(h, 0.4)));
  EXPECT_FALSE(torch::allclose(sample(h, 0.4), sample(3 * h, 0.4)));
}

TEST(NeuralTextureTest, LodFollowsTheGlFormula) {
  auto lod = [](double dudx, double dvdx, double dudy, double dvdy) {
    const auto d = torch::tensor({dudx, dvdx, dudy, dvdy}, torch::kDouble).reshape({1, 1, 1, 4});
    return MipLod(d, 64, 32, 7).item<double>();
  };
  EXPECT_DOUBLE_EQ(lod(1.0 / 64, 0, 0, 1.0 / 32), 0.0);   // one texel per pixel
  EXPECT_DOUBLE_EQ(lod(4.0 / 64, 0, 0, 1.0 / 32), 2.0);   // the larger axis wins
  EXPECT_DOUBLE_EQ(lod(0, 0, 3.0 / 64, 4.0 / 32), std::log2(5.0));
  EXPECT_DOUBLE_EQ(lod(0.1 / 64, 0, 0, 0), 0.0);          // magnification clamps to 0
  EXPECT_DOUBLE_EQ(lod(0, 0, 0, 0), 0.0);
  EXPECT_DOUBLE_EQ(lod(1000, 0, 0, 0), 6.0);              // clamps to the last level
}

TEST(NeuralTextureTest, GradientMatchesFiniteDifferences) {
  NeuralTexture texture = MakeTexture(4, 1, 5);  // 5 x 4 x 4 = 80 texels, 3 levels
  torch::Tensor uv, derivatives;
  torch::manual_seed(6);
  RandomQuery(1, 5, 6, &uv, &derivatives);
  const auto coverage = torch::rand({1, 1, 5, 6}, torch::kDouble);
  const auto weights = torch::randn({1, 5, 5, 6}, torch::kDouble);
  auto loss_fn = [&] { return (texture->forward(uv, derivatives, coverage) * weights).sum(); };
  texture->zero_grad();
  loss_fn().backward();
  const auto analytic = texture->texels().grad().clone().flatten();
  ASSERT_GT(analytic.abs().max().item<double>(), 1e-3);  // the check must see gradients
  auto flat = texture->texels().data().view({-1});
  const double eps = 1e-6;
  double max_error = 0;
  for (int64_t i = 0; i < flat.numel(); ++i) {
    torch::NoGradGuard no_grad;
    const double original = flat[i].item<double>();
    flat[i] = original + eps;
    const double plus = loss_fn().item<double>();
    flat[i] = original - eps;
    const double minus = loss_fn().item<double>();
    flat[i] = original;
    max_error = std::max(max_error, std::abs((plus - minus) / (2 * eps) - analytic[i].item<double>()));
  }
  EXPECT_LT(max_error, 1e-7);
}

TEST(NeuralTextureTest, CoarseLevelsAreAveragesOfLevelZero) {
  NeuralTexture texture = MakeTexture(8, 1, 7);
  const auto chain = BuildMipChain(texture->texels().detach(), texture->options().levels());
  ASSERT_EQ(chain.size(), 4u);
  EXPECT_EQ(chain[3].sizes(), (std::vector<int64_t>{1, 5, 1, 1}));
  EXPECT_TRUE(torch::allclose(chain[3].flatten(), texture->texels().detach().mean({2, 3}).flatten()));
  // A pixel whose footprint covers the whole texture reads the 1x1 level.
  const auto uv = torch::full({1, 1, 1, 2}, 0.3, torch::kDouble);
  const auto d = torch::tensor({8.0, 0.0, 0.0, 8.0}, torch::kDouble).reshape({1, 1, 1, 4});
  const auto out = texture->forward(uv, d, torch::ones({1, 1, 1, 1}, torch::kDouble));
  EXPECT_TRUE(torch::allclose(out.flatten(), chain[3].flatten()));
}

TEST(NeuralTextureTest, UncoveredPixelsAreZeroEvenWithNanUv) {
  NeuralTexture texture = MakeTexture(8, 1, 8);
  auto uv = torch::full({1, 2, 2, 2}, std::nan(""), torch::kDouble);
  uv.index_put_({0, 0, 0}, torch::tensor({0.5, 0.5}, torch::kDouble));
  auto d = torch::full({1, 2, 2, 4}, std::nan(""), torch::kDouble);
  d.index_put_({0, 0, 0}, torch::zeros({4}, torch::kDouble));
  auto coverage = torch::zeros({1, 1, 2, 2}, torch::kDouble);
  coverage.index_put_({0, 0, 0, 0}, 1.0);
  const auto out = texture->forward(uv, d, coverage);
  EXPECT_TRUE(torch::isfinite(out).all().item<bool>());
  EXPECT_EQ(out.index({0, torch::indexing::Slice(), 1, 1}).abs().sum().item<double>(), 0.0);
  EXPECT_GT(out.index({0, torch::indexing::Slice(), 0, 0}).abs().sum().item<double>(), 0.0);
}

TEST(NeuralTextureTest, OptionsAreChecked) {
  NeuralTextureOptions options;
  EXPECT_EQ(options.channels(), 30);
  EXPECT_EQ(options.levels(), 9);
  options.resolution_px = 100;
  EXPECT_THROW(CheckOptions(options), Error);
  options.resolution_px = 64;
  options.mip_levels = 3;
  EXPECT_EQ(options.levels(), 3);
  NeuralTexture texture(options);
  EXPECT_THROW(texture->forward(torch::zeros({1, 4, 4, 3}), torch::zeros({1, 4, 4, 4}), torch::ones({1, 1, 4, 4})),
               Error);
}

}  // namespace
}  // namespace relit::relight
