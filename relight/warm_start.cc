#include "relight/warm_start.h"

#include "core/error.h"
#include "relight/cues_baseline.h"

namespace relit::relight {

constexpr int kCues = 3 * kBasisCount;  // RGB of each basis, [k * 3 + c]

WarmStartResult WarmStartCueRegression(DnlModel& model, const std::vector<Batch>& frames, double ridge) {
  const ModelOptions& options = model->options();
  RELIT_REQUIRE(options.residual(), "warm start: only the residual model variant has a cue regression");
  torch::Tensor& texels = model->regression();
  const int resolution = static_cast<int>(texels.size(3));
  CuesOnlyBaseline fit(resolution, ridge);
  WarmStartResult result;
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
      fit.AccumulatePixel(cue + kCues * i, texcoord[2 * i], texcoord[2 * i + 1], rgb + 3 * i);
    }
  }
  result.pixels = fit.pixels_used();
  fit.Solve();
  auto weights = torch::empty({kCues, resolution, resolution}, torch::kFloat);
  auto w = weights.accessor<float, 3>();
  for (int y = 0; y < resolution; ++y) {
    for (int x = 0; x < resolution; ++x) {
      const auto& texel = fit.Weights(x, y);
      for (int j = 0; j < kCues; ++j) w[j][y][x] = texel[j];
    }
  }
  torch::NoGradGuard no_grad;
  texels[0].copy_(weights.to(texels.device(), texels.scalar_type()));
  result.texels = static_cast<int64_t>(resolution) * resolution;
  result.texels_seen = fit.texels_seen();
  return result;
}

}  // namespace relit::relight
