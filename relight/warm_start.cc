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

// Reads every target pixel (x, y) of frame b at (x + dx, y + dy), bilinear,
// as the smooth fit's alignment did (cue_texture_fit.h).
static void ShiftTargets(Batch& frame, int64_t b, double dx, double dy) {
  if (dx == 0 && dy == 0) return;
  namespace F = torch::nn::functional;
  const int64_t h = frame.height(), w = frame.width();
  const auto xs = (torch::arange(w, torch::kFloat) + dx) * (2.0 / std::max<int64_t>(w - 1, 1)) - 1.0;
  const auto ys = (torch::arange(h, torch::kFloat) + dy) * (2.0 / std::max<int64_t>(h - 1, 1)) - 1.0;
  const auto grid = torch::stack({xs.view({1, w}).expand({h, w}), ys.view({h, 1}).expand({h, w})}, 2).unsqueeze(0);
  const auto options = F::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kBorder).align_corners(true);
  auto shift = [&](torch::Tensor& t) {
    const auto moved = F::grid_sample(t.slice(0, b, b + 1).to(torch::kFloat), grid.to(t.device()), options);
    t.slice(0, b, b + 1).copy_(moved.to(t.scalar_type()));
  };
  shift(frame.target_rgb);
  shift(frame.target_matte);
}

WarmStartResult WarmStartCueRegression(DnlModel& model, std::vector<Batch>& frames, const CueFitOptions& fit,
                                       double per_texel_ridge) {
  const ModelOptions& options = model->options();
  RELIT_REQUIRE(options.residual(), "warm start: only the residual model variant has a cue regression");
  torch::Tensor& texels = model->regression();
  const int resolution = static_cast<int>(texels.size(3));
  for (const Batch& frame : frames) {
    RELIT_REQUIRE(frame.has_targets() && frame.cues.size(1) == kCues, "warm start: frames need targets and 5 cues");
  }
  WarmStartResult result;
  result.texels = static_cast<int64_t>(resolution) * resolution;
  auto weights = torch::empty({kCues, resolution, resolution}, torch::kFloat);
  auto w = weights.accessor<float, 3>();
  if (options.cue_fit == "smooth") {
    CueTextureFit smooth(resolution, fit);
    for (const Batch& frame : frames) {
      for (int64_t b = 0; b < frame.batch_size(); ++b) {
        const auto cues = frame.cues[b].permute({1, 2, 0}).to(torch::kCPU, torch::kFloat).contiguous();
        const auto uv = frame.uv[b].to(torch::kCPU, torch::kFloat).contiguous();
        const auto coverage = frame.coverage[b].to(torch::kCPU, torch::kFloat).contiguous();
        const auto target = frame.target_rgb[b].permute({1, 2, 0}).to(torch::kCPU, torch::kFloat).contiguous();
        const auto matte = frame.target_matte[b].to(torch::kCPU, torch::kFloat).contiguous();
        smooth.AddFrame({static_cast<int>(frame.width()), static_cast<int>(frame.height()), cues.data_ptr<float>(),
                         uv.data_ptr<float>(), coverage.data_ptr<float>(), target.data_ptr<float>(),
                         matte.data_ptr<float>()});
      }
    }
    result.stats = smooth.Solve();
    // The networks train on the aligned targets too.
    int index = 0;
    for (Batch& frame : frames) {
      for (int64_t b = 0; b < frame.batch_size(); ++b) {
        const std::array<double, 2> shift = smooth.FrameShift(index++);
        ShiftTargets(frame, b, shift[0], shift[1]);
      }
    }
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
    result.stats.pixels = per_texel.pixels_used();
    per_texel.Solve();
    result.stats.texels_seen = per_texel.texels_seen();
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
