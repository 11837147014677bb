// Networks of Deferred Neural Lighting.
//
// ResnetGenerator is the pix2pix/CycleGAN "ResNet" image generator:
//   reflection pad 3, 7x7 conv (ngf), IN, ReLU
//   2 x [3x3 conv stride 2 (channels x2), IN, ReLU]               downsampling
//   n_blocks x [pad 1, 3x3 conv, IN, ReLU, pad 1, 3x3 conv, IN] + skip
//   2 x [transposed 3x3 conv stride 2 (or nearest x2 + 3x3 conv), IN, ReLU]
//   reflection pad 3, 7x7 conv (out), optional tanh
// and, with `input_skip`, that last 7x7 conv reads the generator's input
// concatenated to the up-sampled features: per-pixel detail of the input
// (texture x cues) reaches the output without passing the 1/4-resolution
// bottleneck. DNL has no such skip; on CPU budgets it is worth ~5 dB
// (docs/relight.md, "Learning check").
// with instance norm (no affine, no running statistics) throughout, weights
// N(0, 0.02) as in pix2pix. Fully convolutional: any H, W that are multiples
// of 4 (and >= 8) work, so training on random crops is fine.
//
// The renderer network maps the log-encoded (neural texture x cues) input to
// log-encoded RGB (tanh output in [-1, 1]). The mask network maps the
// projected neural texture to a one-channel matte *logit* (no sigmoid: the
// loss is BCE with logits and renders apply the sigmoid once).
#pragma once

#include <string>

#include <nlohmann/json.hpp>
#include <torch/torch.h>
#include "relight/learn_options.h"

namespace relit::relight {


class ResnetBlockImpl : public torch::nn::Module {
 public:
  ResnetBlockImpl(int channels, const std::string& norm);
  torch::Tensor forward(const torch::Tensor& x);

 private:
  torch::nn::Sequential body_;
};
TORCH_MODULE(ResnetBlock);

class ResnetGeneratorImpl : public torch::nn::Module {
 public:
  static constexpr int kDownsamplings = 2;

  explicit ResnetGeneratorImpl(const GeneratorOptions& options);
  // x: [B, input_channels, H, W] -> [B, output_channels, H, W]. Throws
  // relit::Error for sizes that are not multiples of 4 or below 8.
  torch::Tensor forward(const torch::Tensor& x);

  const GeneratorOptions& options() const { return options_; }

 private:
  GeneratorOptions options_;
  torch::nn::Sequential model_;  // up to the last up-sampling stage
  torch::nn::Sequential head_;   // pad, 7x7 conv, tanh
};
TORCH_MODULE(ResnetGenerator);

// Network input of the renderer: the projected texture's channels of basis i
// (channels i C .. i C + C - 1 of `sampled_texture` [B, N C, H, W]) times cue
// i (channels 3 i .. 3 i + 2 of `cues` [B, 3 N, H, W], linear RGB radiance),
// channel k of a basis using cue colour k mod 3; then log-encoded with the
// scene's maximum radiance M. Returns [B, N C, H, W]. N = 5 bases by default.
torch::Tensor BuildNetworkInput(const torch::Tensor& sampled_texture, const torch::Tensor& cues,
                                double max_radiance);

// The per-texel linear regression of the cues (model variant "residual"):
// sum over bases i of weights[3 i + c] times cues[3 i + c], c = 0, 1, 2, from
// `weights` and `cues`, both [B, 3 N, H, W]. Returns linear RGB [B, 3, H, W]
// (may be negative).
torch::Tensor CueRegression(const torch::Tensor& weights, const torch::Tensor& cues);

// Network input of the sh baseline (sh_encoding.h) from `sampled_texture`
// [B, 21 + C, H, W] and the sh light channels `sh` [B, 21, H, W]:
//   [0, 9)    texture 0..8   x view SH (shv)       DNR's view encoding
//   [9, 18)   texture 9..17  x light SH (shl)      the same for the light
//   [18, 21)  LogEncode(texture 18..20 x level RGB)  absolute light level
//   [21, 21+C) texture 21..                         passed through (as DNR)
// Returns [B, 21 + C, H, W].
torch::Tensor BuildShNetworkInput(const torch::Tensor& sampled_texture, const torch::Tensor& sh,
                                  double max_radiance);

}  // namespace relit::relight
