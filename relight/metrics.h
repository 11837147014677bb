// Image metrics for relit results, in linear radiance on the object.
//
// The foreground is where the reference matte is >= 0.5. There the
// prediction (premultiplied linear RGBA) is compared with reference RGB x
// matte, so both sides carry the same edge blending.
//   MAE   mean absolute error over foreground pixels and RGB channels
//   PSNR  10 log10(peak^2 / MSE), peak = 1 (linear 1.0 = the captures' SDR
//         white), same pixels
//   alpha MAE: mean |alpha - matte| over the whole image
// A capture cannot hold radiance above its white level, so eval clips both
// sides there first (ClipRadiance, eval.clip_radiance).
#pragma once

#include "core/image.h"

namespace relit::relight {

struct ImageMetrics {
  double mae = 0;
  double mse = 0;
  double psnr_db = 0;
  double alpha_mae = 0;
  int64_t foreground_pixels = 0;
};

// `predicted`: >= 4 channels (premultiplied R,G,B,A); `reference_rgb`: >= 3
// channels; `matte`: >= 1 channel. All the same size.
ImageMetrics CompareToReference(const Image& predicted, const Image& reference_rgb, const Image& matte);

// Averages (MAE, MSE, alpha MAE) over images, weighting by foreground pixels;
// PSNR from the pooled MSE.
ImageMetrics PoolMetrics(const std::vector<ImageMetrics>& metrics);

double PsnrFromMse(double mse);

// The captured frames' linear white level: relit-capture linearises sRGB /
// gamma 2.2 video to 1 = white, so nothing captured is brighter.
constexpr double kCaptureWhiteLevel = 1.0;

// Clamps the RGB channels (the first 3; alpha and others untouched) to
// [0, white_level]: what an 8-bit capture can hold once linearised (its
// linear white level, 1 for SDR sRGB video). white_level <= 0: unchanged.
void ClipRadiance(Image* image, double white_level);

}  // namespace relit::relight
