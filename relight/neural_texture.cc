#include "relight/neural_texture.h"

#include <cmath>

#include "core/error.h"
#include "core/options.h"

namespace relit::relight {
namespace {

namespace F = torch::nn::functional;

void CheckPixelTensor(const torch::Tensor& t, const char* name, int64_t last_dim) {
  RELIT_REQUIRE(t.defined() && t.dim() == 4 && t.size(3) == last_dim, "neural texture: ", name,
                " must be [B, H, W, ", last_dim, "], got ", t.defined() ? t.sizes() : c10::IntArrayRef{});
}

}  // namespace





torch::Tensor MipLod(const torch::Tensor& derivatives, int64_t width, int64_t height, int levels) {
  CheckPixelTensor(derivatives, "uv derivatives", 4);
  torch::NoGradGuard no_grad;  // the LOD only selects levels; it is not learned
  const auto d = derivatives.permute({0, 3, 1, 2});  // [B, 4, H, W]
  const double w = static_cast<double>(width), h = static_cast<double>(height);
  const auto dx = torch::sqrt(torch::square(d.select(1, 0) * w) + torch::square(d.select(1, 1) * h));
  const auto dy = torch::sqrt(torch::square(d.select(1, 2) * w) + torch::square(d.select(1, 3) * h));
  // log2(0) = -inf clamps to level 0, as magnification does in OpenGL.
  return torch::log2(torch::maximum(dx, dy)).clamp(0.0, levels - 1.0).unsqueeze(1);
}

std::vector<torch::Tensor> BuildMipChain(const torch::Tensor& level0, int levels) {
  std::vector<torch::Tensor> chain = {level0};
  for (int l = 1; l < levels; ++l) {
    const auto& prev = chain.back();
    RELIT_CHECK(prev.size(2) >= 2 && prev.size(3) >= 2);
    chain.push_back(F::avg_pool2d(prev, F::AvgPool2dFuncOptions(2).stride(2)));
  }
  return chain;
}

torch::Tensor SampleMipChain(const std::vector<torch::Tensor>& chain, const torch::Tensor& uv,
                             const torch::Tensor& lod) {
  CheckPixelTensor(uv, "uv", 2);
  const int64_t batch = uv.size(0);
  // grid_sample's x runs left to right, y top to bottom, both over [-1, 1]
  // with align_corners = false mapping -1 to the outer edge of the first
  // texel. v is up, so y = 1 - 2 v.
  const auto grid = torch::stack({uv.select(3, 0) * 2.0 - 1.0, 1.0 - uv.select(3, 1) * 2.0}, 3);
  const auto sample_options = F::GridSampleFuncOptions()
                                  .mode(torch::kBilinear)
                                  .padding_mode(torch::kBorder)
                                  .align_corners(false);
  // Only levels some pixel actually reads: lod <= max_lod.
  const double max_lod = lod.numel() > 0 ? lod.max().item<double>() : 0.0;
  const int levels = static_cast<int>(chain.size());
  const int used = std::isfinite(max_lod) ? std::min(levels, static_cast<int>(std::floor(max_lod)) + 2) : levels;
  torch::Tensor result;
  for (int l = 0; l < used; ++l) {
    // Tent weight: 1 - |lod - l| clipped at 0 gives (1 - f) and f for the
    // two levels around lod, 0 elsewhere.
    const auto weight = torch::relu(1.0 - torch::abs(lod - static_cast<double>(l)));
    const auto level = chain[l].expand({batch, -1, -1, -1});
    const auto sampled = F::grid_sample(level, grid, sample_options) * weight;
    result = result.defined() ? result + sampled : sampled;
  }
  return result;
}

NeuralTextureImpl::NeuralTextureImpl(const NeuralTextureOptions& options) : options_(options) {
  CheckOptions(options_, "texture");
  const int64_t r = options_.resolution_px;
  texels_ = register_parameter(
      "texels", torch::empty({1, options_.channels(), r, r}).uniform_(options_.init_min, options_.init_max));
}

torch::Tensor NeuralTextureImpl::forward(const torch::Tensor& uv_in, const torch::Tensor& derivatives_in,
                                         const torch::Tensor& coverage) {
  CheckPixelTensor(uv_in, "uv", 2);
  CheckPixelTensor(derivatives_in, "uv derivatives", 4);
  const auto b = uv_in.size(0), h = uv_in.size(1), w = uv_in.size(2);
  RELIT_REQUIRE(derivatives_in.size(0) == b && derivatives_in.size(1) == h && derivatives_in.size(2) == w,
                "neural texture: uv ", uv_in.sizes(), " and derivatives ", derivatives_in.sizes(),
                " differ in size");
  RELIT_REQUIRE(coverage.defined() && coverage.dim() == 4 && coverage.size(0) == b && coverage.size(1) == 1 &&
                    coverage.size(2) == h && coverage.size(3) == w,
                "neural texture: coverage must be [B, 1, H, W] = [", b, ", 1, ", h, ", ", w, "], got ",
                coverage.defined() ? coverage.sizes() : c10::IntArrayRef{});
  // Zero the coordinates of uncovered pixels so junk (NaN) there cannot leak
  // into the LOD maximum or, through 0 * NaN, into the output.
  const auto covered = (coverage > 0).permute({0, 2, 3, 1});  // [B, H, W, 1]
  const auto uv = torch::where(covered, uv_in, torch::zeros_like(uv_in));
  const auto derivatives = torch::where(covered, derivatives_in, torch::zeros_like(derivatives_in));
  const int levels = options_.levels();
  const auto lod = MipLod(derivatives, texels_.size(3), texels_.size(2), levels);
  const auto chain = BuildMipChain(texels_, levels);
  return SampleMipChain(chain, uv.to(texels_.dtype()), lod.to(texels_.dtype())) * coverage.to(texels_.dtype());
}

namespace {
// `texels` [1, S, R, R] at level 0 only, times the coverage.
torch::Tensor SampleLevel0(const torch::Tensor& texels, const torch::Tensor& uv_in, const torch::Tensor& coverage,
                           bool nearest) {
  CheckPixelTensor(uv_in, "uv", 2);
  const auto covered = (coverage > 0).permute({0, 2, 3, 1});
  const auto uv = torch::where(covered, uv_in, torch::zeros_like(uv_in)).to(texels.dtype());
  const auto grid = torch::stack({uv.select(3, 0) * 2.0 - 1.0, 1.0 - uv.select(3, 1) * 2.0}, 3);
  auto options = F::GridSampleFuncOptions().padding_mode(torch::kBorder).align_corners(false);
  if (nearest) {
    options = options.mode(torch::kNearest);
  } else {
    options = options.mode(torch::kBilinear);
  }
  return F::grid_sample(texels.expand({uv.size(0), -1, -1, -1}), grid, options) * coverage.to(texels.dtype());
}
}  // namespace

torch::Tensor SampleNearest(const torch::Tensor& texels, const torch::Tensor& uv, const torch::Tensor& coverage) {
  return SampleLevel0(texels, uv, coverage, /*nearest=*/true);
}

torch::Tensor SampleBilinear(const torch::Tensor& texels, const torch::Tensor& uv, const torch::Tensor& coverage) {
  return SampleLevel0(texels, uv, coverage, /*nearest=*/false);
}

}  // namespace relit::relight
