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
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/option_fields.h"

namespace relit::relight {

// Premultiplied linear RGBA of a cue frame (channels as cue_frames.h,
// default format) under per-pixel cue weights: rgb_c = max(0, sum_k
// w[k * 3 + c] cue_kc) with w = weights_at(u, v) (the cues are pixel
// averages, so already premultiplied), alpha = the proxy's coverage. What
// both cue regressions (this one and cues_baseline.h) predict.
Image PredictFromCueWeights(const Image& cue_frame,
                            const std::function<std::array<float, 15>(float u, float v)>& weights_at);

struct CueFitOptions {
  // Smoothness of the Lambert weight and of the 4 GGX weights (pixels'
  // worth per neighbour pair, on unit-RMS cues). The GGX weights at 2
  // followed the training lights' noise and cost 0.2-0.4 dB at eval lights
  // (demo cue fit 10 / 30 / 100 level within 0.05 dB; docs/relight.md).
  double smoothness_diffuse = 0.2;
  double smoothness_specular = 30.0;
  double ridge = 1e-3;           // pull towards the global fit (pixels' worth)
  int iterations_per_level = 60;  // conjugate-gradient iterations at each level
  double tolerance = 1e-5;       // relative residual that ends a level early
  int coarse_levels = 3;         // levels below the final resolution (each half the size)
  int64_t max_pixels = 4000000;  // pixels kept (evenly strided) when the frames hold more
  // > 0: a training pixel's channel at or above this linear level is
  // clipped: the video only says the radiance was at least that, so the fit
  // asks its prediction to be at least the observed value (a one-sided,
  // squared-hinge term; active-set rounds below) instead of equal to it.
  // Fitting clipped pixels as equal pulls the weights of bright surfaces
  // down, and every eval light then renders the object too dark. Sensor
  // noise spreads a clipped pixel below the white level (8-bit video of a
  // white surface at the demo's distances reads 0.93-1.0), hence 0.9 for
  // SDR video. 0 = every pixel is an equality; -1 (auto) = 0.9 when phone
  // V's video was SDR (capture.json transfer srgb or gamma2.2), else 0
  // (HDR video keeps highlights; rendered test workspaces are not clipped).
  double saturation_level = kAutoSaturationLevel;
  int saturation_rounds = 4;  // active-set rounds for the clipped pixels
  // How far above its reading a clipped channel is asked to be: the
  // one-sided fit alone leaves a channel clipped in every frame that sees
  // it brightly at its lowest value, below the truth (the demo's white and
  // pink cow came out short of red: cyan specks under dimmer lights).
  // -1 (auto): the median, over the clipped channels, of how far above its
  // reading the one-sided fit predicts each (at least 1), i.e. how much the
  // frames that do pin a texel down say clipped pixels overshoot; the fit
  // is then solved again with every clipped reading times that factor as
  // its lower bound. 1 = the reading itself.
  // clip_model "lift" only.
  double clip_overshoot = kAutoClipOvershoot;
  static constexpr double kAutoClipOvershoot = -1.0;
  // How a clipped channel enters the fit after the one-sided rounds:
  // "censored": as censored data (a Tobit model), by EM rounds that
  // replace each clipped reading r with the radiance expected above it under
  // the fit's prediction and the noise the unclipped bright pixels show,
  // E[y | y >= r] = pred + sigma phi(a) / (1 - Phi(a)), a = (r - pred) /
  // sigma, sigma = relative noise x r. Noise makes the bright pixels that
  // stay below the clip the ones whose noise pulled them down, so a fit of
  // them and of one-sided bounds sits low; each clipped pixel pushes its
  // texel up by what its own prediction and the noise say, no global
  // factor. "lift": every clipped reading times clip_overshoot is a lower
  // bound. Censored scores better on the `full` spot and on extrapolation
  // views, 0.19 dB worse on the demo's interpolation views, its goal's
  // margin; lift stays the default (docs/relight.md, "Clipped readings as
  // censored data").
  std::string clip_model = "lift";
  int censored_rounds = 4;  // EM rounds of the censored model (each a solve at the final level)
  static constexpr double kAutoSaturationLevel = -1.0;
  static constexpr double kSdrSaturationLevel = 0.9;
  // Frames added whole (AddFrame) are aligned to the fit: after each solve,
  // every frame's image (and matte) is shifted by the sub-pixel translation
  // that best matches the fit's prediction (Gauss-Newton on the image
  // gradient), then the fit is solved again. A pose or lens error of a
  // pixel moves the photo's texture off the proxy's atlas coordinates,
  // which on a high-contrast texture costs more than any model error.
  // Off by default: on the demo it cost 0.3-0.4 dB (docs/relight.md).
  int align_rounds = 0;          // 0 = no alignment
  double max_shift_px = 3.0;     // largest shift a frame may take
  // Robust fit: after the least-squares solve, rounds of iteratively
  // reweighted least squares with Cauchy weights 1 / (1 + (e / (scale x
  // sigma))^2), e a pixel's RMS residual over its channels and sigma 1.4826 x
  // the median e (the MAD, at least 1 % of the targets' RMS); each texel keeps
  // its pixels' total weight. Pixels that no cue weights explain then pull
  // their texels less: the printed board mirrored by glossy paint, glints, a
  // texture edge that the proxy misplaces in one view. Off by default: it
  // helps where the proxy is wrong and costs where the inputs are right
  // (docs/relight.md, "Robust rounds"). 0 = least squares.
  int robust_rounds = 0;
  double robust_scale = 1.0;

  static const OptionFields<CueFitOptions>& Fields();
  void Check() const;  // saturation_level >= 0 or auto; ranges: CheckOptions
};

// `level` itself when >= 0; auto (< 0): kSdrSaturationLevel for a capture
// linearised from SDR video (`capture_transfer` srgb or gamma2.2), else 0.
double ResolveSaturationLevel(double level, const std::string& capture_transfer);

struct CueFitStats {
  int64_t pixels = 0;       // foreground pixels fitted
  int64_t saturated_pixels = 0;  // foreground pixels with a clipped channel (fitted one-sided)
  int64_t saturated_above = 0;   // of their clipped channels, those the fit predicts above the observed value
  double clip_overshoot = 1;     // the factor clipped readings were lifted by (clip_model lift), else 1
  double clip_noise = 0;         // clip_model censored: the relative noise (1.4826 x MAD of residual / prediction) of bright unclipped channels
  double clip_mean_lift = 1;     // clip_model censored: mean over clipped channels of fitted target / reading
  int64_t texels_seen = 0;  // texels of the final level with pixel weight
  int iterations = 0;       // conjugate-gradient iterations, all levels and channels
  double rms_residual = 0;  // training pixels, linear, all channels
  double robust_sigma = 0;        // the last robust round's residual scale (1.4826 x median), linear
  double robust_downweighted = 0; // share of pixels the last robust round weighted below 0.5
  double median_shift_px = 0;  // frames' alignment shifts (0 without AddFrame or align_rounds)
  double max_shift_px = 0;

  nlohmann::json ToJson() const;
};

class CueTextureFit {
 public:
  static constexpr int kBases = 5;
  static constexpr int kWeights = 3 * kBases;  // [k * 3 + c] per texel

  CueTextureFit(int resolution_px, const CueFitOptions& options);

  // One foreground pixel: its 5 cues' RGB ([k * 3 + c]), texture
  // coordinates (OBJ convention, v up) and linear target RGB (left out when
  // clipped, see CueFitOptions).
  void AddPixel(const float* cues, float u, float v, const float* target_rgb);
  // The foreground pixels (matte >= 0.5, coverage >= 0.5) of a cue frame
  // (channels as cue_frames.h, default format) with its target and matte.
  // The frame is kept (cropped to the proxy's box) for the alignment.
  void AddFrame(const Image& cue_frame, const Image& target_rgb, const Image& matte);
  // The same from row-major pixel arrays: cues 15, uv 2, coverage 1,
  // target RGB 3 and matte 1 floats per pixel.
  struct FramePixels {
    int width = 0, height = 0;
    const float* cues = nullptr;
    const float* uv = nullptr;
    const float* coverage = nullptr;
    const float* target_rgb = nullptr;
    const float* matte = nullptr;
  };
  void AddFrame(const FramePixels& frame);
  CueFitStats Solve();
  // A fit solved elsewhere (a model's warm start, train_stage.h): `weights`
  // laid out as Weight() reads them, resolution_px^2 x kWeights floats.
  void SetWeights(std::vector<float> weights);

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

  // After Solve(): the translation (pixels) by which the i-th frame added
  // (AddFrame order, from 0) was aligned: its target pixel (x, y) is read at
  // (x + dx, y + dy). (0, 0) for a frame without coverage or dropped by the
  // frame budget.
  std::array<double, 2> FrameShift(int i) const;

  int resolution() const { return resolution_; }
  // Foreground pixels held (loose pixels kept by the budget plus the frames'
  // foreground).
  int64_t pixels() const { return static_cast<int64_t>(loose_.size()) + frame_pixels_; }

 private:
  struct Sample {
    float u, v;
    std::array<float, kWeights> cues;
    std::array<float, 3> target;
    uint8_t clipped = 0;  // bit c: channel c at or above the saturation level
    std::array<float, 3> expected{};  // clip_model censored: a clipped channel's expected radiance
    float weight = 1;     // the robust rounds' weight of this pixel's data term
  };
  // A frame kept for alignment: its crop around the proxy's coverage.
  struct Frame {
    int index = 0;  // AddFrame order
    int left = 0, top = 0, width = 0, height = 0;
    std::vector<float> cues, uv, coverage, target, matte;  // crop, row-major
    std::array<double, 2> shift{0, 0};
  };
  // samples_ = the loose pixels + every frame's foreground read at its shift.
  void BuildSamples();
  void MarkClipped(Sample* s) const;
  bool IsClipped(double value) const;  // at or above the saturation level
  // Solves all channels: coarse to fine from the global fit (first call)
  // or at the final level from the current weights.
  int SolveWeights(bool from_scratch);
  // Gauss-Newton update of each frame's shift against the current fit.
  void AlignFrames();
  // Conjugate gradients for colour channel c at `resolution`, from (and
  // into) *z: [texel * 5 + k], weights on unit-RMS cues. Returns iterations.
  // Clipped channels count only while in active_[c] (predicted below
  // their observed value).
  int SolveChannel(int c, int resolution, const Eigen::Matrix<double, kBases, 1>& global,
                   std::vector<double>* z) const;
  // What the fit asks of channel c of `s`: its reading, or for a clipped
  // channel the reading x clip_overshoot_ (a lower bound), or in the
  // censored rounds the radiance expected above the reading (an equality).
  double Bound(const Sample& s, int c) const {
    if (!(s.clipped >> c & 1)) return s.target[c];
    return censored_ ? s.expected[c] : clip_overshoot_ * s.target[c];
  }
  // Clipped channels: the lower bound the residual and active sets use.
  double LowerBound(const Sample& s, int c) const {
    return censored_ ? s.target[c] : clip_overshoot_ * s.target[c];
  }
  // The median over clipped channels of max(1, prediction / reading).
  double MedianClipOvershoot() const;
  // The censored model's EM rounds (clip_model censored); returns CG
  // iterations and records the noise and mean lift in *stats.
  int SolveCensored(CueFitStats* stats);
  // 1.4826 x the median |residual| / prediction over unclipped channels
  // predicted between 0.3 and 1 x the saturation level.
  double BrightRelativeNoise() const;
  // Puts each clipped channel predicted below its bound into the
  // active set; returns how many changed.
  int64_t UpdateActiveSets();
  // Active-set rounds (saturation_rounds) at the final level; returns CG iterations.
  int SolveClipped();
  // BuildSamples with every clipped channel active.
  void PrepareSamples();
  // The robust rounds (CueFitOptions::robust_rounds) from the current
  // solution; returns CG iterations and records the last round in *stats.
  int SolveRobust(CueFitStats* stats);
  // A pixel's RMS residual over its channels under its weights `w` (WeightsAt).
  double Residual(const Sample& s, const std::array<float, kWeights>& w) const;

  int resolution_;
  CueFitOptions options_;
  std::vector<Sample> samples_;  // what the solver fits
  std::vector<Sample> loose_;    // from AddPixel
  std::vector<Frame> frames_;    // from AddFrame
  int64_t frame_pixels_ = 0;     // foreground pixels in frames_
  double clip_overshoot_ = 1.0;  // the lift of clipped readings in use (Bound)
  bool censored_ = false;        // clipped channels fitted as equal to Sample::expected
  int frames_added_ = 0;
  std::array<Eigen::Matrix<double, kBases, 1>, 3> global_;
  std::array<std::vector<double>, 3> z_;  // per channel, [texel * 5 + k], on unit-RMS cues
  int64_t offered_ = 0;  // pixels offered to AddPixel (samples_ may keep fewer)
  int64_t stride_ = 1;   // samples_ holds every stride-th pixel offered
  std::array<std::vector<char>, 3> active_;  // per channel and sample: clipped channel fitted as equal
  std::array<float, kWeights> cue_scale_{};  // RMS of each cue channel
  std::vector<float> weights_;  // [texel][k * 3 + c], unscaled
  bool solved_ = false;
};

}  // namespace relit::relight
