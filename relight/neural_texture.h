// Learnable neural texture with differentiable trilinear mip filtering.
//
// The texture has S = 5 x C channels (C per basis material of the radiance
// cues) over the proxy mesh's UV atlas. Only level 0 is a parameter; coarser
// mip levels are 2x2 averages computed in every forward pass, so gradients of
// samples taken from any level flow back to level 0.
//
// Per output pixel the inputs are (B batch, H x W image):
//   uv          [B, H, W, 2]  texture coordinates in OBJ convention: u to the
//                             right, v UP the texture image, so texel row
//                             (1 - v) * height (row 0 is the top, v = 1);
//   derivatives [B, H, W, 4]  dudx, dvdx, dudy, dvdy per pixel (screen-space
//                             derivatives, as written by the renderer's AOVs);
//   coverage    [B, 1, H, W]  fraction of the pixel covered by the proxy.
// Filtering follows OpenGL: texel-space footprint
//   rho = max(|(dudx W, dvdx H)|, |(dudy W, dvdy H)|),  lod = clamp(log2 rho, 0, L-1)
// (W, H of level 0), bilinear within a level with clamp-to-edge addressing,
// linear between the two nearest levels. Texel centres sit at (i + 0.5) / W.
// The result is multiplied by the coverage, so uncovered pixels read zero
// (their uv is ignored, it may be anything, even NaN).
#pragma once

#include <vector>

#include <nlohmann/json.hpp>
#include <torch/torch.h>
#include "relight/learn_options.h"

namespace relit {
class OptionsReader;
}

namespace relit::relight {

// Basis materials of the radiance cues: Lambert + GGX alpha 0.02/0.05/0.13/0.34.

// Level-of-detail per pixel: [B, 1, H, W] from derivatives [B, H, W, 4], for a
// level-0 size of width x height texels and `levels` mip levels.
torch::Tensor MipLod(const torch::Tensor& derivatives, int64_t width, int64_t height, int levels);

// 2x2 average pyramid of `level0` [N, S, H, W]: `levels` tensors, level 0
// first. Differentiable.
std::vector<torch::Tensor> BuildMipChain(const torch::Tensor& level0, int levels);

// Trilinear sampling of a mip chain (see the file comment). Returns
// [B, S, H, W] (not multiplied by any coverage).
torch::Tensor SampleMipChain(const std::vector<torch::Tensor>& chain, const torch::Tensor& uv,
                             const torch::Tensor& lod);

// `texels` [1, S, R, R] read at the nearest texel of level 0, no filtering:
// [B, S, H, W] times `coverage` [B, 1, H, W] (uncovered pixels read zero).
// Texel (floor(u R), floor((1 - v) R)), as the cues-only baseline indexes
// (cues_baseline.h): the residual model's least-squares weights are read
// exactly as they were fitted. Bilinear or mip filtering would blend
// neighbouring texels' weights, which only agree on the cues each texel saw.
torch::Tensor SampleNearest(const torch::Tensor& texels, const torch::Tensor& uv, const torch::Tensor& coverage);
// The same, bilinear between the 4 nearest texel centres ((x + 0.5) / R),
// clamped at the border: how the smooth cue fit (cue_texture_fit.h) reads
// the weights it fitted.
torch::Tensor SampleBilinear(const torch::Tensor& texels, const torch::Tensor& uv, const torch::Tensor& coverage);

class NeuralTextureImpl : public torch::nn::Module {
 public:
  explicit NeuralTextureImpl(const NeuralTextureOptions& options);

  // Sampled texture [B, S, H, W] times coverage.
  torch::Tensor forward(const torch::Tensor& uv, const torch::Tensor& derivatives,
                        const torch::Tensor& coverage);

  const NeuralTextureOptions& options() const { return options_; }
  // Level 0, [1, S, resolution, resolution].
  torch::Tensor& texels() { return texels_; }

 private:
  NeuralTextureOptions options_;
  torch::Tensor texels_;
};
TORCH_MODULE(NeuralTexture);

}  // namespace relit::relight
