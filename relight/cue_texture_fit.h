// The smooth cue fit: a texture of per-texel cue weights, read with bilinear
// interpolation, fitted to the training frames by sparse least squares,
//
//   rgb_c(pixel) = sum_k W_kc(uv(pixel)) cue_kc(pixel)        (c = R, G, B)
//   min_W  sum_pixels (rgb_c - target_c)^2
//          + sum_k lambda_k sum_(4-neighbour texels t, t') (W_kc(t) - W_kc(t'))^2
//          + ridge sum_t |W_c(t) - W_c,global|^2
//
// with the cues scaled to unit RMS, so lambda and the ridge count in pixels'
// worth. Unlike the per-texel fit (cues_baseline.h), a texel shares the
// evidence of its neighbours: the Lambert weight (the albedo) may follow the
// texture's detail (small lambda), the specular weights vary slowly (large
// lambda), so the texture can be as fine as the pixels while each weight is
// still pinned down by many pixels. Texels without pixels take the smooth
// continuation of their neighbours, which is what bilinear reads at chart
// borders need. Solved per colour channel by preconditioned conjugate
// gradients (block-Jacobi), coarse to fine (each level starts from the
// previous, coarser solution), without forming the matrix.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/image.h"

namespace relit {
class OptionsReader;
}

namespace relit::relight {

struct CueFitOptions {
  // Smoothness of the Lambert weight and of the 4 GGX weights (pixels'
  // worth per neighbour pair, on unit-RMS cues).
  double smoothness_diffuse = 0.2;
  double smoothness_specular = 2.0;
  double ridge = 1e-3;           // pull towards the global fit (pixels' worth)
  int iterations_per_level = 60;  // conjugate-gradient iterations at each level
  double tolerance = 1e-5;       // relative residual that ends a level early
  int coarse_levels = 3;         // levels below the final resolution (each half the size)
  int64_t max_pixels = 4000000;  // pixels kept (evenly strided) when the frames hold more
  // Training pixels with any channel at or above this linear level are left
  // out: a clipped pixel only says the radiance was at least the white level
  // (SDR video: 1), and fitting it as equal pulls the weights of bright
  // surfaces down. 0 = keep every pixel (HDR captures without clipping).
  double saturation_level = kDefaultSaturationLevel;
  static constexpr double kDefaultSaturationLevel = 0.99;

  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

struct CueFitStats {
  int64_t pixels = 0;       // foreground pixels fitted
  int64_t saturated_pixels = 0;  // foreground pixels left out as clipped
  int64_t texels_seen = 0;  // texels of the final level with pixel weight
  int iterations = 0;       // conjugate-gradient iterations, all levels and channels
  double rms_residual = 0;  // training pixels, linear, all channels
};

class CueTextureFit {
 public:
  static constexpr int kBases = 5;
  static constexpr int kWeights = 3 * kBases;  // [k * 3 + c] per texel

  CueTextureFit(int resolution_px, const CueFitOptions& options);

  // One foreground pixel: its 5 cues' RGB ([k * 3 + c]), texture
  // coordinates (OBJ convention, v up) and linear target RGB (left out when
  // saturated, see CueFitOptions).
  void AddPixel(const float* cues, float u, float v, const float* target_rgb);
  // The foreground pixels (matte >= 0.5, coverage >= 0.5) of a cue frame
  // (channels as cue_frames.h, default format) with its target and matte.
  void AddFrame(const Image& cue_frame, const Image& target_rgb, const Image& matte);
  CueFitStats Solve();

  // After Solve(): weights of texel row y (row 0 at v = 1), column x.
  float Weight(int x, int y, int j) const {
    return weights_[(static_cast<size_t>(y) * resolution_ + x) * kWeights + j];
  }
  // Weights at (u, v), bilinear with texel centres at (x + 0.5) / R and
  // clamped at the border, as torch's grid_sample(align_corners = false,
  // padding border) reads them.
  std::array<float, kWeights> WeightsAt(float u, float v) const;
  // Premultiplied linear RGBA for a cue frame; alpha = proxy coverage.
  Image Predict(const Image& cue_frame) const;

  int resolution() const { return resolution_; }
  int64_t pixels() const { return static_cast<int64_t>(samples_.size()); }
  int64_t saturated_pixels() const { return saturated_; }

 private:
  struct Sample {
    float u, v;
    std::array<float, kWeights> cues;
    std::array<float, 3> target;
  };
  // Conjugate gradients for colour channel c at `resolution`, from (and
  // into) *z: [texel * 5 + k], weights on unit-RMS cues. Returns iterations.
  int SolveChannel(int c, int resolution, const Eigen::Matrix<double, kBases, 1>& global,
                   std::vector<double>* z) const;

  int resolution_;
  CueFitOptions options_;
  std::vector<Sample> samples_;
  int64_t offered_ = 0;  // pixels offered to AddPixel (samples_ may keep fewer)
  int64_t stride_ = 1;   // samples_ holds every stride-th pixel offered
  int64_t saturated_ = 0;  // pixels left out at the saturation level
  std::array<float, kWeights> cue_scale_{};  // RMS of each cue channel
  std::vector<float> weights_;  // [texel][k * 3 + c], unscaled
  bool solved_ = false;
};

}  // namespace relit::relight
