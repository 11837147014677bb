// Log encoding of radiance for the networks (DNL, eq. in sec. 4):
//
//   y = 2 (ln(x + 1/e) + 1) / (ln(M + 1/e) + 1) - 1
//
// with M the scene's maximum radiance: x = 0 maps to -1, x = M to +1 and
// larger values beyond 1 (nothing is clamped above). Evaluated in the
// algebraically equal form y = 2 log1p(e x) / log1p(e M) - 1, which makes both
// ends exact in floating point and is accurate for small x. Radiance is
// non-negative; negative inputs (a learnable texture times a cue can go
// below zero) are clamped to 0, i.e. to -1 after encoding.
#pragma once

#include <algorithm>
#include <cmath>

#include <torch/torch.h>

#include "core/error.h"

namespace relit::relight {

class LogEncoding {
 public:
  // `max_radiance` is M, > 0.
  explicit LogEncoding(double max_radiance) : max_radiance_(max_radiance) {
    RELIT_REQUIRE(std::isfinite(max_radiance) && max_radiance > 0,
                  "log encoding: the maximum radiance M must be finite and > 0, got ", max_radiance);
    scale_ = std::log1p(kE * max_radiance);
  }

  double max_radiance() const { return max_radiance_; }

  double Encode(double radiance) const {
    return 2.0 * std::log1p(kE * std::max(radiance, 0.0)) / scale_ - 1.0;
  }
  // Exact inverse of Encode on [0, inf).
  double Decode(double encoded) const { return std::expm1((encoded + 1.0) * 0.5 * scale_) / kE; }

  torch::Tensor Encode(const torch::Tensor& radiance) const {
    return torch::log1p(radiance.clamp_min(0.0) * kE) * (2.0 / scale_) - 1.0;
  }
  torch::Tensor Decode(const torch::Tensor& encoded) const {
    return torch::expm1((encoded + 1.0) * (0.5 * scale_)) * (1.0 / kE);
  }

 private:
  static constexpr double kE = 2.71828182845904523536;
  double max_radiance_;
  double scale_;  // ln(M + 1/e) + 1 = log1p(e M)
};

}  // namespace relit::relight
