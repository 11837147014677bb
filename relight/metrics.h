// Image metrics for relit results, in linear radiance on the object.
//
// The foreground is where the reference matte is >= 0.5. There the
// prediction (premultiplied linear RGBA) is compared with reference RGB x
// matte, so both sides carry the same edge blending.
//   MAE   mean absolute error over foreground pixels and RGB channels
//   PSNR  10 log10(peak^2 / MSE), peak = 1 (linear 1.0 = the captures' SDR
//         white), same pixels
//   alpha MAE: mean |alpha - matte| over the whole image
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

}  // namespace relit::relight
