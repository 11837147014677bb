#include "core/render/cue_denoise.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"

namespace relit::render {

std::vector<double> CueNormalSigmas(const std::vector<CueBasis>& basis, const CueDenoiseOptions& options) {
  std::vector<double> sigmas;
  for (const CueBasis& b : basis) {
    const bool glossy = b.bsdf.specular.maxCoeff() > 0;
    sigmas.push_back(glossy ? options.normal_sigma * std::min(1.0, 2.0 * b.bsdf.alpha) : options.normal_sigma);
  }
  return sigmas;
}

Image DenoiseCues(const RenderResult& aovs, const Image& radiance, const CueDenoiseOptions& options,
                  const std::vector<double>& normal_sigmas) {
  const int width = radiance.width(), height = radiance.height(), channels = radiance.channels();
  RELIT_REQUIRE(aovs.alpha.width() == width && aovs.alpha.height() == height && aovs.normal.width() == width &&
                    aovs.depth.width() == width && aovs.object_id.width() == width,
                "DenoiseCues: the AOVs are ", aovs.alpha.width(), "x", aovs.alpha.height(), ", the cues ", width,
                "x", height);
  RELIT_REQUIRE(options.radius_px >= 0 && options.spatial_sigma_px > 0 && options.normal_sigma > 0 &&
                    options.depth_sigma > 0,
                "DenoiseCues: radius must be >= 0 and every sigma > 0");
  Image out = radiance;
  const int r = options.radius_px;
  if (r == 0) return out;
  // The spatial kernel, tabulated once.
  std::vector<float> spatial((2 * r + 1) * (2 * r + 1));
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const double sigma = options.spatial_sigma_px;
      spatial[(dy + r) * (2 * r + 1) + dx + r] =
          static_cast<float>(std::exp(-0.5 * (dx * dx + dy * dy) / (sigma * sigma)));
    }
  }
  RELIT_REQUIRE(normal_sigmas.empty() || static_cast<int>(normal_sigmas.size()) * 3 == channels,
                "DenoiseCues: ", normal_sigmas.size(), " normal sigmas for ", channels, " channels (one per RGB)");
  // One normal weight per channel group: a triple per sigma, or every channel.
  const int groups = normal_sigmas.empty() ? 1 : static_cast<int>(normal_sigmas.size());
  const int group_channels = normal_sigmas.empty() ? channels : 3;
  std::vector<float> inv_normal(groups);
  for (int g = 0; g < groups; ++g) {
    const double sigma = normal_sigmas.empty() ? options.normal_sigma : normal_sigmas[g];
    RELIT_REQUIRE(sigma > 0, "DenoiseCues: normal sigma ", sigma, " must be > 0");
    inv_normal[g] = static_cast<float>(0.5 / (sigma * sigma));
  }
  const float inv_depth = 0.5f / static_cast<float>(options.depth_sigma * options.depth_sigma);
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 4), [&](const tbb::blocked_range<int>& rows) {
    std::vector<double> sum(channels), weight_sum(groups);
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < width; ++x) {
        const float id = aovs.object_id.at(x, y, 0);
        const float alpha = aovs.alpha.at(x, y, 0);
        const float z = aovs.depth.at(x, y, 0);
        if (id < 0 || alpha <= 0 || z <= 0) continue;
        const float* n = aovs.normal.pixel(x, y);
        std::fill(sum.begin(), sum.end(), 0.0);
        std::fill(weight_sum.begin(), weight_sum.end(), 0.0);
        for (int qy = std::max(0, y - r); qy <= std::min(height - 1, y + r); ++qy) {
          for (int qx = std::max(0, x - r); qx <= std::min(width - 1, x + r); ++qx) {
            const float q_alpha = aovs.alpha.at(qx, qy, 0);
            if (aovs.object_id.at(qx, qy, 0) != id || q_alpha <= 0) continue;
            const float* m = aovs.normal.pixel(qx, qy);
            const float dn =
                (n[0] - m[0]) * (n[0] - m[0]) + (n[1] - m[1]) * (n[1] - m[1]) + (n[2] - m[2]) * (n[2] - m[2]);
            const float dz = (aovs.depth.at(qx, qy, 0) - z) / z;
            const float w_shared = spatial[(qy - y + r) * (2 * r + 1) + qx - x + r] * std::exp(-dz * dz * inv_depth);
            // Unpremultiplied: a partly covered neighbour counts its surface's radiance.
            const float* v = radiance.pixel(qx, qy);
            for (int g = 0; g < groups; ++g) {
              const float w = w_shared * std::exp(-dn * inv_normal[g]);
              for (int c = g * group_channels; c < (g + 1) * group_channels; ++c) sum[c] += w * v[c] / q_alpha;
              weight_sum[g] += w;
            }
          }
        }
        float* o = out.pixel(x, y);
        for (int c = 0; c < channels; ++c) o[c] = static_cast<float>(alpha * sum[c] / weight_sum[c / group_channels]);
      }
    }
  });
  return out;
}

}  // namespace relit::render
