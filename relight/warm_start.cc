#include "relight/warm_start.h"

#include "core/error.h"
#include "relight/cue_texture_fit.h"

namespace relit::relight {

constexpr int kCues = 3 * kBasisCount;  // RGB of each basis, [k * 3 + c]

namespace {

// Calls add(cues, u, v, rgb) for every pixel with matte >= 0.5 and proxy
// coverage >= 0.5 of the frames.
template <typename AddPixel>
void ForEachForegroundPixel(const std::vector<Batch>& frames, AddPixel add) {
  for (const Batch& frame : frames) {
    RELIT_REQUIRE(frame.has_targets() && frame.cues.size(1) == kCues, "warm start: frames need targets and 5 cues");
    // [B, H, W, C] contiguous float views of the per-pixel tensors.
    const auto cues = frame.cues.permute({0, 2, 3, 1}).to(torch::kCPU, torch::kFloat).contiguous();
    const auto target = frame.target_rgb.permute({0, 2, 3, 1}).to(torch::kCPU, torch::kFloat).contiguous();
    const auto uv = frame.uv.to(torch::kCPU, torch::kFloat).contiguous();
    const auto matte = frame.target_matte.to(torch::kCPU, torch::kFloat).contiguous();
    const auto coverage = frame.coverage.to(torch::kCPU, torch::kFloat).contiguous();
    const int64_t pixels = frame.batch_size() * frame.height() * frame.width();
    const float* cue = cues.data_ptr<float>();
    const float* rgb = target.data_ptr<float>();
    const float* texcoord = uv.data_ptr<float>();
    const float* alpha = matte.data_ptr<float>();
    const float* covered = coverage.data_ptr<float>();
    for (int64_t i = 0; i < pixels; ++i) {
      if (alpha[i] < 0.5f || covered[i] < 0.5f) continue;
      add(cue + kCues * i, texcoord[2 * i], texcoord[2 * i + 1], rgb + 3 * i);
    }
  }
}

}  // namespace

WarmStartResult WarmStartCueRegression(DnlModel& model, const std::vector<Batch>& frames, const CueFitOptions& fit,
                                       double per_texel_ridge) {
  const ModelOptions& options = model->options();
  RELIT_REQUIRE(options.residual(), "warm start: only the residual model variant has a cue regression");
  torch::Tensor& texels = model->regression();
  const int resolution = static_cast<int>(texels.size(3));
  WarmStartResult result;
  result.texels = static_cast<int64_t>(resolution) * resolution;
  auto weights = torch::empty({kCues, resolution, resolution}, torch::kFloat);
  auto w = weights.accessor<float, 3>();
  if (options.cue_fit == "smooth") {
    CueTextureFit smooth(resolution, fit);
    ForEachForegroundPixel(frames, [&](const float* cues, float u, float v, const float* rgb) {
      smooth.AddPixel(cues, u, v, rgb);
    });
    const CueFitStats stats = smooth.Solve();
    result.pixels = stats.pixels;
    result.saturated_pixels = stats.saturated_pixels;
    result.texels_seen = stats.texels_seen;
    result.iterations = stats.iterations;
    result.rms_residual = stats.rms_residual;
    for (int y = 0; y < resolution; ++y) {
      for (int x = 0; x < resolution; ++x) {
        for (int j = 0; j < kCues; ++j) w[j][y][x] = smooth.Weight(x, y, j);
      }
    }
  } else {
    CuesOnlyBaseline per_texel(resolution, per_texel_ridge);
    ForEachForegroundPixel(frames, [&](const float* cues, float u, float v, const float* rgb) {
      per_texel.AccumulatePixel(cues, u, v, rgb);
    });
    result.pixels = per_texel.pixels_used();
    per_texel.Solve();
    result.texels_seen = per_texel.texels_seen();
    for (int y = 0; y < resolution; ++y) {
      for (int x = 0; x < resolution; ++x) {
        const auto& texel = per_texel.Weights(x, y);
        for (int j = 0; j < kCues; ++j) w[j][y][x] = texel[j];
      }
    }
  }
  torch::NoGradGuard no_grad;
  texels[0].copy_(weights.to(texels.device(), texels.scalar_type()));
  return result;
}

}  // namespace relit::relight
