#include "relight/networks.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/error.h"
#include "relight/log_encoding.h"
#include "relight/model.h"
#include "relight/test_scene.h"

namespace relit::relight {
namespace {

using torch::indexing::Slice;

TEST(LogEncodingTest, EndsAreExactAndInverseRoundTrips) {
  for (double m : {0.5, 1.0, 7.3, 1000.0}) {
    const LogEncoding enc(m);
    EXPECT_EQ(enc.Encode(0.0), -1.0);
    EXPECT_EQ(enc.Encode(m), 1.0);
    EXPECT_EQ(enc.Decode(-1.0), 0.0);
    EXPECT_NEAR(enc.Decode(1.0), m, 1e-12 * m);
    // The formula as written in the paper.
    const double x = 0.37 * m;
    const double paper = 2.0 * (std::log(x + std::exp(-1.0)) + 1.0) / (std::log(m + std::exp(-1.0)) + 1.0) - 1.0;
    EXPECT_NEAR(enc.Encode(x), paper, 1e-12);
    for (double v : {1e-6, 0.01, 0.5, 3.0, 50.0, 2000.0}) {
      EXPECT_NEAR(enc.Decode(enc.Encode(v)), v, 1e-12 * std::max(1.0, v)) << v;
    }
  }
  const LogEncoding enc(4.0);
  const auto x = torch::tensor({-2.0, 0.0, 0.25, 4.0, 9.0}, torch::kDouble);
  const auto y = enc.Encode(x);
  for (int i = 0; i < 5; ++i) EXPECT_NEAR(y[i].item<double>(), enc.Encode(x[i].item<double>()), 1e-14);
  EXPECT_EQ(y[0].item<double>(), -1.0);  // negative radiance clamps to 0
  EXPECT_TRUE(torch::allclose(enc.Decode(y).slice(0, 1), x.slice(0, 1), 1e-12, 1e-14));
  EXPECT_THROW(LogEncoding(0.0), Error);
}

TEST(NetworkInputTest, EachBasisIsMultipliedByItsTiledCue) {
  const int c = 4, h = 3, w = 2;
  const auto texture = torch::rand({2, kBasisCount * c, h, w}, torch::kDouble) + 0.1;
  const auto cues = torch::rand({2, 15, h, w}, torch::kDouble) * 5.0;
  const double m = 6.0;
  const auto input = BuildNetworkInput(texture, cues, m);
  ASSERT_EQ(input.sizes(), texture.sizes());
  const LogEncoding enc(m);
  for (int basis = 0; basis < kBasisCount; ++basis) {
    for (int k = 0; k < c; ++k) {
      const auto expected = enc.Encode(texture.select(1, basis * c + k) * cues.select(1, 3 * basis + k % 3));
      EXPECT_TRUE(torch::allclose(input.select(1, basis * c + k), expected)) << basis << " " << k;
    }
  }
  EXPECT_THROW(BuildNetworkInput(texture, cues.slice(1, 0, 14), m), Error);  // not RGB triples
  EXPECT_THROW(BuildNetworkInput(texture, cues.slice(1, 0, 9), m), Error);   // 3 bases do not divide 5 C
  // One basis (Lambert): every texture channel times the Lambert cue.
  const auto one = BuildNetworkInput(texture.slice(1, 0, c), cues.slice(1, 0, 3), m);
  for (int k = 0; k < c; ++k) {
    EXPECT_TRUE(torch::allclose(one.select(1, k), enc.Encode(texture.select(1, k) * cues.select(1, k % 3))));
  }
}

TEST(NetworkInputTest, ShInputModulatesDirectionsAndEncodesTheLevel) {
  const int c = 3, h = 4, w = 5;
  const auto texture = torch::randn({1, 21 + c, h, w}, torch::kDouble);
  const auto sh = torch::randn({1, 21, h, w}, torch::kDouble);
  const double m = 4.0;
  const auto input = BuildShNetworkInput(texture, sh.abs(), m);
  ASSERT_EQ(input.sizes(), texture.sizes());
  const LogEncoding enc(m);
  for (int k = 0; k < 18; ++k) {
    EXPECT_TRUE(torch::allclose(input.select(1, k), texture.select(1, k) * sh.abs().select(1, k))) << k;
  }
  for (int k = 18; k < 21; ++k) {
    EXPECT_TRUE(torch::allclose(input.select(1, k), enc.Encode(texture.select(1, k) * sh.abs().select(1, k)))) << k;
  }
  EXPECT_TRUE(torch::equal(input.slice(1, 21), texture.slice(1, 21)));
  EXPECT_THROW(BuildShNetworkInput(texture, sh.slice(1, 0, 15), m), Error);
  EXPECT_THROW(BuildShNetworkInput(texture.slice(1, 0, 21), sh, m), Error);  // no pass-through channel
}

TEST(GeneratorTest, ShapesRangeAndSizeChecks) {
  torch::manual_seed(1);
  for (const char* upsampling : {"transposed", "resize_conv"}) {
    GeneratorOptions options;
    options.input_channels = 10;
    options.ngf = 8;
    options.n_blocks = 2;
    options.upsampling = upsampling;
    ResnetGenerator net(options);
    for (int64_t size : {8, 20, 32}) {
      const auto out = net->forward(torch::randn({2, 10, size, size + 4}) * 3.0);
      EXPECT_EQ(out.sizes(), (std::vector<int64_t>{2, 3, size, size + 4}));
      EXPECT_LE(out.abs().max().item<double>(), 1.0);  // tanh
    }
    EXPECT_THROW(net->forward(torch::randn({1, 10, 18, 16})), Error);
    EXPECT_THROW(net->forward(torch::randn({1, 10, 4, 4})), Error);
    EXPECT_THROW(net->forward(torch::randn({1, 9, 16, 16})), Error);
  }
  GeneratorOptions bad;
  bad.upsampling = "bicubic";
  EXPECT_THROW(bad.Check(), Error);
}

TEST(GeneratorTest, ResidualBlocksAndWidthsAsSpecified) {
  GeneratorOptions options;
  options.input_channels = 30;
  options.ngf = 16;
  options.n_blocks = 3;
  ResnetGenerator net(options);
  int64_t params = 0;
  for (const auto& p : net->parameters()) params += p.numel();
  // 7x7 in, two stride-2 convs, 3 blocks of two 3x3 convs at 4 ngf, two
  // transposed convs, 7x7 out (weights + biases).
  const int64_t n = 16;
  const int64_t expected = (30 * n * 49 + n) + (n * 2 * n * 9 + 2 * n) + (2 * n * 4 * n * 9 + 4 * n) +
                           3 * 2 * (4 * n * 4 * n * 9 + 4 * n) + (4 * n * 2 * n * 9 + 2 * n) +
                           (2 * n * n * 9 + n) + (n * 3 * 49 + 3);
  EXPECT_EQ(params, expected);
}

TEST(DnlModelTest, ForwardWithCoverageIsFiniteAndRenderIsPremultiplied) {
  torch::manual_seed(2);
  const auto material = testing::SyntheticMaterial(3);
  Batch batch = testing::SyntheticFrame(material, 24, 0, 4);
  // Junk uv outside the coverage must not matter.
  const auto outside = (batch.coverage == 0).permute({0, 2, 3, 1});
  batch.uv = torch::where(outside, torch::full_like(batch.uv, NAN), batch.uv);
  ModelOptions options = testing::TinyModelOptions();
  DnlModel model(options);
  const ModelOutput out = model->Forward(batch);
  EXPECT_EQ(out.rgb_log.sizes(), (std::vector<int64_t>{1, 3, 24, 24}));
  EXPECT_EQ(out.mask_logit.sizes(), (std::vector<int64_t>{1, 1, 24, 24}));
  EXPECT_TRUE(torch::isfinite(out.rgb_log).all().item<bool>());
  EXPECT_TRUE(torch::isfinite(out.mask_logit).all().item<bool>());
  const Losses losses = model->Loss(out, batch);
  EXPECT_TRUE(std::isfinite(losses.total.item<double>()));
  const auto rgba = model->Render(batch);
  ASSERT_EQ(rgba.size(1), 4);
  const auto alpha = rgba.slice(1, 3, 4);
  EXPECT_GE(alpha.min().item<double>(), 0.0);
  EXPECT_LE(alpha.max().item<double>(), 1.0);
  const auto rgb = model->encoding().Decode(out.rgb_log.detach()) * torch::sigmoid(out.mask_logit.detach());
  EXPECT_TRUE(torch::allclose(rgba.slice(1, 0, 3), rgb, 1e-5, 1e-6));
  options.max_radiance = 0;
  EXPECT_THROW(DnlModel{options}, Error);
}

TEST(DnlModelTest, LossIsMaskedL1InLogSpacePlusBceWithLogits) {
  torch::manual_seed(5);
  const auto material = testing::SyntheticMaterial(3);
  Batch batch = testing::SyntheticFrame(material, 16, 1, 4);
  ModelOptions options = testing::TinyModelOptions();
  options.mask_correction = true;  // else the residual variant has no mask loss
  DnlModel model(options);
  ModelOutput out;
  out.rgb_log = torch::rand({1, 3, 16, 16}) * 2 - 1;
  out.mask_logit = torch::randn({1, 1, 16, 16}) * 3;
  const Losses losses = model->Loss(out, batch);
  // Hand-computed.
  const auto& matte = batch.target_matte;
  const auto target_log = model->encoding().Encode(batch.target_rgb);
  const double rgb = ((out.rgb_log - target_log).abs() * matte).sum().item<double>() / (3 * matte.sum().item<double>());
  const auto p = torch::sigmoid(out.mask_logit);
  const double bce = -(matte * torch::log(p) + (1 - matte) * torch::log(1 - p)).mean().item<double>();
  EXPECT_NEAR(losses.rgb.item<double>(), rgb, 1e-5);
  EXPECT_NEAR(losses.mask.item<double>(), bce, 1e-5);
  EXPECT_NEAR(losses.total.item<double>(), rgb + bce, 1e-5);
  // Targets outside the matte do not count.
  Batch changed = batch;
  changed.target_rgb = batch.target_rgb + (1 - matte) * 100.0;
  EXPECT_NEAR(model->Loss(out, changed).rgb.item<double>(), rgb, 1e-5);
}

// An 8 x 8 frame whose target reads 1 in every channel and pixel: clipped
// at a saturation level of 0.9.
Batch AllClippedFrame() {
  Batch batch = testing::SyntheticFrame(testing::SyntheticMaterial(3), 8, 0, 4);
  batch.target_matte = torch::ones_like(batch.target_matte);
  batch.target_rgb = torch::full_like(batch.target_rgb, 1.0);
  return batch;
}

// A clipped target channel only bounds the output from below: an output
// brighter than it costs nothing, a darker one costs as before.
TEST(DnlModelTest, LossIsOneSidedOnClippedTargets) {
  const Batch batch = AllClippedFrame();
  DnlModel model(testing::TinyModelOptions());
  const auto target_log = model->encoding().Encode(batch.target_rgb);
  ModelOutput out;
  out.mask_logit = torch::zeros({1, 1, 8, 8});
  out.rgb_log = target_log + 0.3;  // brighter than the clipped reading
  EXPECT_GT(model->Loss(out, batch, 1.0, 0).rgb.item<double>(), 0.29);
  EXPECT_NEAR(model->Loss(out, batch, 1.0, 0.9).rgb.item<double>(), 0.0, 1e-7);
  out.rgb_log = target_log - 0.3;  // darker: still an error
  EXPECT_NEAR(model->Loss(out, batch, 1.0, 0.9).rgb.item<double>(), 0.3, 1e-5);
}

// With the cue fit's lift, the bound is the reading x factor: an output
// between the reading and the lifted bound now costs, one above it does not.
TEST(DnlModelTest, ClippedTargetsBoundTheOutputAtTheLiftedReading) {
  const Batch batch = AllClippedFrame();
  DnlModel model(testing::TinyModelOptions());
  const auto lifted_log = model->encoding().Encode(batch.target_rgb * 1.3);
  ModelOutput out;
  out.mask_logit = torch::zeros({1, 1, 8, 8});
  out.rgb_log = lifted_log - 0.1;  // above the reading, below the lifted bound
  EXPECT_NEAR(model->Loss(out, batch, 1.0, 0.9, 1.0).rgb.item<double>(), 0.0, 1e-7);
  EXPECT_NEAR(model->Loss(out, batch, 1.0, 0.9, 1.3).rgb.item<double>(), 0.1, 1e-5);
  out.rgb_log = lifted_log + 0.1;
  EXPECT_NEAR(model->Loss(out, batch, 1.0, 0.9, 1.3).rgb.item<double>(), 0.0, 1e-7);
  EXPECT_THROW(model->Loss(out, batch, 1.0, 0.9, 0.5), Error);
}

// The censored model (the cue fit's clip_model censored): below its reading
// a clipped target costs as the L1 (plus the constant b ln 2 of a Laplace at
// the reading), above it the cost falls off as b x -log(1 - e^(-d / b) / 2)
// and still pulls the output up.
TEST(DnlModelTest, CensoredLossCostsBelowTheReadingAndPushesUpAbove) {
  const Batch batch = AllClippedFrame();  // every target 1, at or above the level
  DnlModel model(testing::TinyModelOptions());
  const double level = 0.9, noise = 0.1;
  const double level_log = model->encoding().Encode(1.0);
  const double b = std::sqrt(2.0 / M_PI) * (model->encoding().Encode(1.0 * (1 + noise)) - level_log);
  auto loss_at = [&](double offset) {
    ModelOutput out;
    out.mask_logit = torch::zeros({1, 1, 8, 8});
    out.rgb_log = torch::full({1, 3, 8, 8}, level_log + offset, torch::requires_grad());
    const auto rgb = model->Loss(out, batch, 1.0, level, 1.0, noise).rgb;
    rgb.backward();
    return std::make_pair(rgb.item<double>(), out.rgb_log.grad().sum().item<double>());
  };
  EXPECT_GT(b, 0.0);
  EXPECT_NEAR(loss_at(-0.2).first, 0.2 + b * std::log(2.0), 1e-5);
  EXPECT_NEAR(loss_at(0.0).first, b * std::log(2.0), 1e-5);
  const auto [loss_above, gradient_above] = loss_at(b);
  EXPECT_NEAR(loss_above, -b * std::log1p(-0.5 * std::exp(-1.0)), 1e-5);
  EXPECT_LT(gradient_above, 0.0);  // descent raises the output
  EXPECT_LT(loss_at(20 * b).first, 1e-6);
  EXPECT_THROW(model->Loss(ModelOutput{torch::zeros({1, 3, 8, 8}), torch::zeros({1, 1, 8, 8})}, batch, 1.0, level,
                           1.0, -0.1),
               Error);
}

TEST(CropTest, CropsEveryPerPixelTensorConsistently) {
  const int64_t h = 12, w = 16;
  const auto rows = torch::arange(h, torch::kFloat).view({1, 1, h, 1}).expand({2, 1, h, w});
  const auto cols = torch::arange(w, torch::kFloat).view({1, 1, 1, w}).expand({2, 1, h, w});
  const auto id = rows * 100 + cols;  // [2, 1, H, W]
  Batch batch;
  batch.uv = torch::cat({id, id}, 1).permute({0, 2, 3, 1});
  batch.uv_derivatives = torch::cat({id, id, id, id}, 1).permute({0, 2, 3, 1});
  batch.coverage = id;
  batch.cues = id.expand({2, 15, h, w});
  batch.target_rgb = id.expand({2, 3, h, w});
  batch.target_matte = id;
  batch.Check(true);
  const Batch crop = CropBatch(batch, 3, 5, 8, 8);
  crop.Check(true);
  EXPECT_EQ(crop.height(), 8);
  EXPECT_EQ(crop.width(), 8);
  const float expected = 3 * 100 + 5;
  EXPECT_EQ(crop.uv[1][0][0][1].item<float>(), expected);
  EXPECT_EQ(crop.uv_derivatives[0][7][7][3].item<float>(), expected + 707);
  EXPECT_EQ(crop.coverage[0][0][0][0].item<float>(), expected);
  EXPECT_EQ(crop.cues[1][14][2][1].item<float>(), expected + 201);
  EXPECT_EQ(crop.target_rgb[0][2][7][0].item<float>(), expected + 700);
  EXPECT_EQ(crop.target_matte[1][0][0][7].item<float>(), expected + 7);
  EXPECT_THROW(CropBatch(batch, 5, 0, 8, 8), Error);
  // Random crops stay inside and follow the generator.
  auto gen_a = at::make_generator<at::CPUGeneratorImpl>(9);
  auto gen_b = at::make_generator<at::CPUGeneratorImpl>(9);
  for (int i = 0; i < 20; ++i) {
    const Batch a = RandomCrop(batch, 8, gen_a), b = RandomCrop(batch, 8, gen_b);
    EXPECT_EQ(a.height(), 8);
    const float corner = a.coverage[0][0][0][0].item<float>();
    EXPECT_EQ(corner, b.coverage[0][0][0][0].item<float>());
    EXPECT_LE(static_cast<int>(corner) / 100, 4);
    EXPECT_LE(static_cast<int>(corner) % 100, 8);
  }
  EXPECT_EQ(RandomCrop(batch, 0, gen_a).height(), h);
}

// The object window: the coverage's bounding box plus the margin, aligned to
// 4 pixels and clipped to the frame; the whole frame when nothing is covered.
TEST(CropTest, ObjectWindowFramesTheCoveredPixels) {
  Batch batch;
  const int64_t h = 40, w = 64;
  batch.uv = torch::zeros({1, h, w, 2});
  batch.uv_derivatives = torch::zeros({1, h, w, 4});
  batch.cues = torch::zeros({1, 15, h, w});
  batch.coverage = torch::zeros({1, 1, h, w});
  EXPECT_EQ(ObjectWindow(batch, 4).width(), w);
  batch.coverage.slice(2, 13, 19).slice(3, 30, 35).fill_(1.0);  // rows 13..18, columns 30..34
  int64_t top = -1, left = -1;
  const Batch window = ObjectWindow(batch, 4, &top, &left);
  EXPECT_EQ(top, 8);       // 13 - 4 = 9, down to a multiple of 4
  EXPECT_EQ(left, 24);     // 30 - 4 = 26 -> 24
  EXPECT_EQ(window.height(), 16);  // rows 8 .. 24 (19 + 4 = 23, up to 24)
  EXPECT_EQ(window.width(), 16);   // columns 24 .. 40 (35 + 4 = 39 -> 40)
  EXPECT_EQ(window.coverage.sum().item<float>(), 30.0f);
  int64_t edge_top = -1;
  batch.coverage.zero_();
  batch.coverage.slice(2, 0, 2).slice(3, 0, 2).fill_(1.0);
  const Batch corner = ObjectWindow(batch, 0, &edge_top);
  EXPECT_EQ(edge_top, 0);
  EXPECT_EQ(corner.height(), 8);  // the generator's minimum
  EXPECT_EQ(corner.width(), 8);
}

TEST(NetworkInputTest, CueRegressionSumsWeightTimesCuePerColour) {
  const auto weights = torch::arange(15, torch::kFloat).view({1, 15, 1, 1}).expand({2, 15, 3, 4});
  const auto cues = torch::full({2, 15, 3, 4}, 0.5f);
  const auto rgb = CueRegression(weights, cues);
  ASSERT_EQ(rgb.sizes(), (std::vector<int64_t>{2, 3, 3, 4}));
  // Colour c: 0.5 * (c + (3 + c) + (6 + c) + (9 + c) + (12 + c)) = 0.5 * (30 + 5 c).
  for (int c = 0; c < 3; ++c) EXPECT_FLOAT_EQ(rgb[1][c][2][3].item<float>(), 0.5f * (30 + 5 * c));
  EXPECT_THROW(CueRegression(weights.slice(1, 0, 12), cues), Error);
}

}  // namespace
}  // namespace relit::relight
