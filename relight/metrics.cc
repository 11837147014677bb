#include "relight/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace relit::relight {

double PsnrFromMse(double mse) {
  return mse > 0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
}

ImageMetrics CompareToReference(const Image& predicted, const Image& reference_rgb, const Image& matte) {
  RELIT_REQUIRE(predicted.channels() >= 4 && reference_rgb.channels() >= 3 && matte.channels() >= 1,
                "metrics: need RGBA prediction, RGB reference and a matte");
  RELIT_REQUIRE(predicted.width() == reference_rgb.width() && predicted.height() == reference_rgb.height() &&
                    predicted.width() == matte.width() && predicted.height() == matte.height(),
                "metrics: image sizes differ (", predicted.width(), "x", predicted.height(), " vs ",
                reference_rgb.width(), "x", reference_rgb.height(), " vs ", matte.width(), "x", matte.height(), ")");
  ImageMetrics m;
  double abs_sum = 0, sq_sum = 0, alpha_sum = 0;
  for (int y = 0; y < predicted.height(); ++y) {
    for (int x = 0; x < predicted.width(); ++x) {
      const float* p = predicted.pixel(x, y);
      const float* r = reference_rgb.pixel(x, y);
      const double a = matte.at(x, y, 0);
      alpha_sum += std::abs(p[3] - a);
      if (a < 0.5) continue;
      ++m.foreground_pixels;
      for (int c = 0; c < 3; ++c) {
        const double d = p[c] - r[c] * a;
        abs_sum += std::abs(d);
        sq_sum += d * d;
      }
    }
  }
  m.alpha_mae = alpha_sum / static_cast<double>(predicted.pixel_count());
  if (m.foreground_pixels > 0) {
    m.mae = abs_sum / (3.0 * m.foreground_pixels);
    m.mse = sq_sum / (3.0 * m.foreground_pixels);
  }
  m.psnr_db = PsnrFromMse(m.mse);
  return m;
}

void ClipRadiance(Image* image, double white_level) {
  if (white_level <= 0) return;
  RELIT_REQUIRE(image->channels() >= 3, "ClipRadiance: need RGB, got ", image->channels(), " channels");
  const float level = static_cast<float>(white_level);
  for (int y = 0; y < image->height(); ++y) {
    for (int x = 0; x < image->width(); ++x) {
      float* p = image->pixel(x, y);
      for (int c = 0; c < 3; ++c) p[c] = std::clamp(p[c], 0.0f, level);
    }
  }
}

ImageMetrics PoolMetrics(const std::vector<ImageMetrics>& metrics) {
  ImageMetrics pooled;
  double alpha = 0;
  for (const ImageMetrics& m : metrics) {
    pooled.mae += m.mae * m.foreground_pixels;
    pooled.mse += m.mse * m.foreground_pixels;
    pooled.foreground_pixels += m.foreground_pixels;
    alpha += m.alpha_mae;
  }
  if (pooled.foreground_pixels > 0) {
    pooled.mae /= pooled.foreground_pixels;
    pooled.mse /= pooled.foreground_pixels;
  }
  pooled.alpha_mae = metrics.empty() ? 0 : alpha / metrics.size();
  pooled.psnr_db = PsnrFromMse(pooled.mse);
  return pooled;
}

}  // namespace relit::relight
