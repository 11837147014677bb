// Clock offset between two recordings of the same room sound, by GCC-PHAT
// (generalised cross-correlation with phase transform) and sub-sample peak
// interpolation.
#pragma once

#include <vector>

namespace relit::capture {

struct LagEstimate {
  double lag_s = 0;          // see GccPhatLag
  double confidence = 0;     // peak / best peak outside the exclusion zone
  double peak = 0;           // GCC-PHAT value at the main peak
  double second_peak = 0;    // best value outside +-exclusion of the main peak
  double second_lag_s = 0;
};

// Finds the lag d (seconds, |d| <= max_lag_s) that best explains
// a[n] ~ b[n - d * rate]: if `b` started recording d seconds after `a`, the
// same sound is at sample n in `a` and n - d * rate in `b`, and d > 0.
// The whitened cross-spectrum makes the peak sharp for broadband sounds
// (claps, noise); the peak is refined with a parabola through three samples.
// Throws relit::Error when a signal is empty or silent.
LagEstimate GccPhatLag(const std::vector<float>& a, const std::vector<float>& b, int rate_hz,
                       double max_lag_s, double exclusion_s);

}  // namespace relit::capture
