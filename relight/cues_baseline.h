// The "cues only" baseline: no network, just a per-texel linear combination
// of the 5 radiance cues,
//   rgb_c(pixel) = sum_k w[texel(pixel)][k][c] * cue_k,c(pixel)   (c = R, G, B)
// with the weights fitted by least squares over every training pixel that
// lands on the texel (nearest texel of a resolution_px^2 grid over the
// atlas). Texels seen by few pixels are pulled towards the global fit by a
// ridge term, so unseen texels predict the average material. It is what the
// cues alone can explain; the neural model must beat it (docs/relight.md).
#pragma once

#include <array>
#include <vector>

#include "core/image.h"
#include "relight/cue_texture_fit.h"

namespace relit::relight {

class CuesOnlyBaseline {
 public:
  // `ridge`: weight of the pull towards the global fit, relative to one
  // pixel's contribution.
  static constexpr double kDefaultRidge = 4.0;
  // Training pixels with any channel at or above `saturation_level` are
  // left out; 0 (the default, the plain per-texel baseline) keeps them all.
  explicit CuesOnlyBaseline(int resolution_px = 128, double ridge = kDefaultRidge, double saturation_level = 0);

  // Adds the foreground pixels (matte >= 0.5, coverage >= 0.5) of one
  // training frame: a cue frame (channels as cue_frames.h), the linear
  // target RGB and its matte.
  void Accumulate(const Image& cue_frame, const Image& target_rgb, const Image& matte);
  // One foreground pixel: its 5 cues' RGB ([k * 3 + c]), texture coordinates
  // and linear target RGB (for callers with their own frame layout).
  void AccumulatePixel(const float* cues, float u, float v, const float* target_rgb);
  void Solve();
  // After Solve(): the weights of texel row y, column x (row 0 at v = 1),
  // [k * 3 + c], the texture layout of the model's cue regression.
  const std::array<float, 15>& Weights(int x, int y) const { return weights_[static_cast<size_t>(y) * resolution_ + x]; }

  // Premultiplied linear RGBA for a cue frame; alpha = proxy coverage.
  Image Predict(const Image& cue_frame) const;

  int resolution() const { return resolution_; }
  int64_t pixels_used() const { return pixels_used_; }
  // Texels with at least one training pixel.
  int64_t texels_seen() const;

 private:
  static constexpr int kBases = 5;
  // Per texel and channel: upper triangle of A (15) and b (5).
  struct Normal {
    std::array<double, 15> a{};
    std::array<double, 5> b{};
    double count = 0;
  };
  int Texel(float u, float v) const;
  static void Add(Normal& n, const double* cue, double target);

  int resolution_;
  double ridge_;
  double saturation_level_;
  std::vector<Normal> normals_;                        // texel * 3 + channel
  std::array<Normal, 3> global_{};
  std::vector<std::array<float, kBases * 3>> weights_;  // per texel: [k * 3 + c]
  int64_t pixels_used_ = 0;
  bool solved_ = false;
};

}  // namespace relit::relight
