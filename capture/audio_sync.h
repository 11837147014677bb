// Clock offset between two recordings of the same room sound, by GCC-PHAT
// (generalised cross-correlation with phase transform) and sub-sample peak
// interpolation.
#pragma once

#include <string>
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

// A mono track with the presentation time of its first sample.
struct TimedSamples {
  const std::vector<float>* samples = nullptr;
  double start_s = 0;
  int rate_hz = 0;
  double end_s() const { return start_s + static_cast<double>(samples->size()) / rate_hz; }
};

// The offset measured in one window of the overlap.
struct DriftWindow {
  double light_time_s = 0;  // window centre on phone L's clock
  double offset_s = 0;      // t_view - t_light there
  double confidence = 0;
};

// Clock drift: two phones' clocks run at slightly different rates, so the
// offset changes along the recording. Linear model
//   t_view = intercept_s + (1 + rate) * t_light,
// fitted (least squares) to the offsets of 2..8 windows spread over the overlap.
struct DriftEstimate {
  bool valid = false;
  std::string reason;                  // why not valid
  double window_s = 0;
  std::vector<DriftWindow> windows;    // those with confidence >= the minimum
  double intercept_s = 0, rate = 0;
  double overlap_start_s = 0, overlap_end_s = 0;  // on phone L's clock
  double offset_at_start_s = 0, offset_at_end_s = 0;
  double ms_per_min() const { return rate * 60e3; }
  double ToView(double light_time_s) const { return intercept_s + (1 + rate) * light_time_s; }
};

// Estimates the drift around a global offset (t_view = t_light + offset_s):
// each window of phone L's track is matched against phone V's track near the
// same time, within +-max_lag_s. Windows that are silent or whose confidence
// is below min_confidence are left out; fewer than two left = not valid.
DriftEstimate EstimateDrift(const TimedSamples& view, const TimedSamples& light, double offset_s,
                            double window_s, double max_lag_s, double min_confidence);

}  // namespace relit::capture
