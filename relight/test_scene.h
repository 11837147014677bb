// Test helper: tiny synthetic relighting problems built from torch ops.
//
// A "true" material (5 smooth per-texel weights in [0, 1]) is seen through a
// per-frame affine uv mapping inside a disk-shaped object; the radiance cues
// are smooth positive blobs around a per-frame light position, sharper for
// the glossier bases; the target is a fixed nonlinear function of both:
//   target = (sum_i material_i(uv) * cue_i) ^ 0.8 inside the disk, 0 outside.
// Not a renderer: only a learnable mapping with the shapes of the real data.
#pragma once

#include <cmath>
#include <cstdint>

#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include "relight/model.h"
#include "relight/sh_encoding.h"

namespace relit::relight::testing {

// Material [1, 5, 64, 64] in [0, 1]: bilinear upsampling of 4 x 4 noise.
inline torch::Tensor SyntheticMaterial(uint64_t seed) {
  torch::manual_seed(seed);
  const auto coarse = torch::rand({1, kBasisCount, 4, 4}, torch::kDouble);
  return torch::nn::functional::interpolate(
      coarse, torch::nn::functional::InterpolateFuncOptions()
                  .size(std::vector<int64_t>{64, 64})
                  .mode(torch::kBilinear)
                  .align_corners(true));
}

// Frame `frame` (size x size pixels) of the problem with the given material.
inline Batch SyntheticFrame(const torch::Tensor& material, int size, int frame, uint64_t seed) {
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed * 1000 + static_cast<uint64_t>(frame));
  const auto dopt = torch::TensorOptions().dtype(torch::kDouble);
  auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * torch::rand({1}, gen, dopt).item<double>();
  };
  // Pixel centres in [-1, 1].
  const auto coords = (torch::arange(size, dopt) + 0.5) / size * 2.0 - 1.0;
  const auto grid = torch::meshgrid({coords, coords}, "ij");
  const auto py = grid[0], px = grid[1];  // [H, W], y down
  // Per-frame rotation and scale of the uv mapping around the atlas centre.
  const double angle = uniform(-0.6, 0.6), scale = uniform(0.35, 0.45);
  const double c = std::cos(angle) * scale, s = std::sin(angle) * scale;
  const auto u = 0.5 + c * px - s * py;
  const auto v = 0.5 - (s * px + c * py);  // v up, image y down
  const auto uv = torch::stack({u, v}, -1).unsqueeze(0);
  const double step = 2.0 / size;  // pixel size in [-1, 1] units
  const auto derivatives =
      torch::tensor({c * step, -s * step, -s * step, -c * step}, dopt).expand({1, size, size, 4}).contiguous();
  const auto coverage = ((px * px + py * py) < 0.8 * 0.8).to(torch::kDouble).unsqueeze(0).unsqueeze(0);
  // Cues: blobs around the light, Lambert wide, GGX lobes sharper.
  const double lx = uniform(-0.7, 0.7), ly = uniform(-0.7, 0.7);
  const auto dist2 = (px - lx) * (px - lx) + (py - ly) * (py - ly);
  const double widths[kBasisCount] = {1.5, 0.05, 0.1, 0.25, 0.6};
  std::vector<torch::Tensor> cues;
  for (int basis = 0; basis < kBasisCount; ++basis) {
    const auto blob = torch::exp(-dist2 / widths[basis]) * (basis == 0 ? 1.0 : 2.0);
    for (int ch = 0; ch < 3; ++ch) cues.push_back(blob * uniform(0.6, 1.0) * coverage[0][0]);
  }
  const auto cue_tensor = torch::stack(cues, 0).unsqueeze(0);  // [1, 15, H, W]
  // Material at each pixel's uv (bilinear, v up).
  const auto sample_grid = torch::stack({u * 2.0 - 1.0, 1.0 - v * 2.0}, -1).unsqueeze(0);
  const auto m = torch::nn::functional::grid_sample(
      material, sample_grid,
      torch::nn::functional::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kBorder).align_corners(false));
  auto radiance = torch::zeros({1, 3, size, size}, dopt);
  for (int basis = 0; basis < kBasisCount; ++basis) {
    radiance = radiance + m.slice(1, basis, basis + 1) * cue_tensor.slice(1, 3 * basis, 3 * basis + 3);
  }
  Batch batch;
  batch.uv = uv.to(torch::kFloat);
  batch.uv_derivatives = derivatives.to(torch::kFloat);
  batch.coverage = coverage.to(torch::kFloat);
  batch.cues = cue_tensor.to(torch::kFloat);
  batch.target_rgb = (torch::pow(radiance, 0.8) * coverage).to(torch::kFloat);
  batch.target_matte = coverage.to(torch::kFloat);
  return batch;
}

// The same frame for the sh baseline (sh_encoding.h): the light comes from a
// per-frame direction d (polar angle <= 70 deg), the view is along +Z, and
// the target is a material-weighted function of d that only the SH light
// channels reveal:
//   target = (2 (m_0(uv) (0.3 + 0.7 d_z) + 0.5 m_1(uv) (1 + d_x)) colour)^0.8
// batch.cues holds the 21 sh channels (view SH, light SH, level 2).
inline Batch SyntheticShFrame(const torch::Tensor& material, int size, int frame, uint64_t seed) {
  Batch batch = SyntheticFrame(material, size, frame, seed);
  auto gen = at::make_generator<at::CPUGeneratorImpl>(seed * 7919 + static_cast<uint64_t>(frame));
  const double theta = 1.22 * torch::rand({1}, gen, torch::kDouble).item<double>();
  const double phi = 6.283185307179586 * torch::rand({1}, gen, torch::kDouble).item<double>();
  const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
  const auto view = ShBasis(Eigen::Vector3d::UnitZ()), light = ShBasis(d);
  std::vector<double> channels(view.begin(), view.end());
  channels.insert(channels.end(), light.begin(), light.end());
  for (int c = 0; c < 3; ++c) channels.push_back(2.0);
  const auto coverage = batch.coverage.to(torch::kDouble);
  batch.cues = (torch::tensor(channels, torch::kDouble).view({1, -1, 1, 1}) * coverage).to(torch::kFloat);
  const auto uv = batch.uv.to(torch::kDouble);
  const auto grid = torch::stack({uv.select(3, 0) * 2.0 - 1.0, 1.0 - uv.select(3, 1) * 2.0}, -1);
  const auto m = torch::nn::functional::grid_sample(
      material, grid,
      torch::nn::functional::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kBorder).align_corners(false));
  const auto shade = m.slice(1, 0, 1) * (0.3 + 0.7 * d.z()) + 0.5 * m.slice(1, 1, 2) * (1.0 + d.x());
  const auto colour = torch::tensor({1.0, 0.8, 0.6}, torch::kDouble).view({1, 3, 1, 1});
  batch.target_rgb = (torch::pow(2.0 * shade * colour, 0.8) * coverage).to(torch::kFloat);
  return batch;
}

// A default-format batch of random data, size x size pixels: for timing and
// memory, which depend on the sizes only.
inline Batch RandomBatch(int size) {
  Batch b;
  b.uv = torch::rand({1, size, size, 2});
  b.uv_derivatives = torch::full({1, size, size, 4}, 1.0 / 512);
  b.coverage = torch::ones({1, 1, size, size});
  b.cues = torch::rand({1, kCueChannelCount, size, size}) * 2.0;
  b.target_rgb = torch::rand({1, 3, size, size});
  b.target_matte = (torch::rand({1, 1, size, size}) > 0.3).to(torch::kFloat);
  return b;
}

// A small model for tests: 2 channels per basis, 32^2 texture, narrow nets.
inline ModelOptions TinyModelOptions() {
  ModelOptions options;
  options.texture_resolution_px = 32;
  options.channels_per_basis = 2;
  options.ngf = 8;
  options.n_blocks = 2;
  options.mask_ngf = 4;
  options.mask_n_blocks = 1;
  options.max_radiance = 3.0;
  options.output_blur_texels = 0;  // renders exactly what the fits predict (OutputBlurTest blurs)
  return options;
}

}  // namespace relit::relight::testing
