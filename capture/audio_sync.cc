#include "capture/audio_sync.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include <opencv2/core.hpp>

#include "core/error.h"

namespace relit::capture {

namespace {

cv::Mat Spectrum(const std::vector<float>& signal, int size) {
  cv::Mat padded = cv::Mat::zeros(1, size, CV_32F);
  std::copy(signal.begin(), signal.end(), padded.ptr<float>());
  cv::Mat spectrum;
  cv::dft(padded, spectrum, cv::DFT_COMPLEX_OUTPUT);
  return spectrum;
}

bool Silent(const std::vector<float>& signal) {
  return std::all_of(signal.begin(), signal.end(), [](float v) { return v == 0.0f; });
}

}  // namespace

LagEstimate GccPhatLag(const std::vector<float>& a, const std::vector<float>& b, int rate_hz,
                       double max_lag_s, double exclusion_s) {
  RELIT_REQUIRE(a.size() >= 16 && b.size() >= 16, "audio track too short to synchronise (",
                a.size(), " and ", b.size(), " samples)");
  RELIT_REQUIRE(!Silent(a) && !Silent(b), "an audio track is silent, so it cannot be synchronised");
  RELIT_CHECK(rate_hz > 0 && max_lag_s > 0);
  // Zero padding to >= |a| + |b| makes the circular correlation linear.
  const int size = cv::getOptimalDFTSize(static_cast<int>(a.size() + b.size()));
  const cv::Mat spectrum_a = Spectrum(a, size);
  const cv::Mat spectrum_b = Spectrum(b, size);
  cv::Mat cross(1, size, CV_32FC2);
  const auto* pa = spectrum_a.ptr<std::complex<float>>();
  const auto* pb = spectrum_b.ptr<std::complex<float>>();
  auto* pc = cross.ptr<std::complex<float>>();
  double mean_magnitude = 0;
  for (int k = 0; k < size; ++k) {
    pc[k] = pa[k] * std::conj(pb[k]);
    mean_magnitude += std::abs(pc[k]);
  }
  mean_magnitude /= size;
  // Phase transform: keep only the phase, so every frequency votes equally.
  const float floor = static_cast<float>(1e-6 * mean_magnitude + 1e-30);
  for (int k = 0; k < size; ++k) pc[k] /= (std::abs(pc[k]) + floor);
  pc[0] = 0;  // DC carries no timing
  cv::Mat correlation;
  cv::dft(cross, correlation, cv::DFT_INVERSE | cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  const float* r = correlation.ptr<float>();
  // r[k] = sum_n a[n] b[n - k]; negative lags wrap to the end.
  auto at = [&](int64_t lag) { return r[((lag % size) + size) % size]; };
  const int64_t max_lag = std::min<int64_t>(std::llround(max_lag_s * rate_hz), size / 2 - 1);
  const int64_t low = std::max<int64_t>(-max_lag, -(static_cast<int64_t>(b.size()) - 1));
  const int64_t high = std::min<int64_t>(max_lag, static_cast<int64_t>(a.size()) - 1);
  RELIT_CHECK(low <= high);
  int64_t best = low;
  for (int64_t k = low; k <= high; ++k) {
    if (at(k) > at(best)) best = k;
  }
  const int64_t exclusion = std::max<int64_t>(2, std::llround(exclusion_s * rate_hz));
  int64_t second = best;
  float second_value = -1e30f;
  for (int64_t k = low; k <= high; ++k) {
    if (std::abs(k - best) > exclusion && at(k) > second_value) {
      second_value = at(k);
      second = k;
    }
  }
  // Parabola through the peak and its neighbours.
  const double left = at(best - 1), centre = at(best), right = at(best + 1);
  const double curvature = left - 2 * centre + right;
  double delta = curvature < 0 ? 0.5 * (left - right) / curvature : 0.0;
  delta = std::clamp(delta, -0.5, 0.5);
  LagEstimate estimate;
  estimate.lag_s = (static_cast<double>(best) + delta) / rate_hz;
  estimate.peak = centre;
  estimate.second_peak = second_value > -1e29f ? second_value : 0.0;
  estimate.second_lag_s = static_cast<double>(second) / rate_hz;
  estimate.confidence = estimate.second_peak > 0 ? centre / estimate.second_peak
                        : centre > 0            ? 1e6
                                                : 0.0;
  estimate.confidence = std::min(estimate.confidence, 1e6);
  return estimate;
}

namespace {

// Samples [first, first + count) of a track, clamped to the track.
std::vector<float> Slice(const TimedSamples& track, int64_t first, int64_t count, double* start_s) {
  const int64_t size = static_cast<int64_t>(track.samples->size());
  first = std::clamp<int64_t>(first, 0, size);
  const int64_t last = std::clamp<int64_t>(first + count, first, size);
  *start_s = track.start_s + static_cast<double>(first) / track.rate_hz;
  return std::vector<float>(track.samples->begin() + first, track.samples->begin() + last);
}

void FitLine(DriftEstimate* d) {
  double st = 0, so = 0, stt = 0, sto = 0;
  const double n = static_cast<double>(d->windows.size());
  for (const DriftWindow& w : d->windows) {
    st += w.light_time_s;
    so += w.offset_s;
    stt += w.light_time_s * w.light_time_s;
    sto += w.light_time_s * w.offset_s;
  }
  const double denominator = n * stt - st * st;
  d->rate = denominator > 1e-12 ? (n * sto - st * so) / denominator : 0.0;
  // offset(t_light) = intercept + rate * t_light.
  d->intercept_s = (so - d->rate * st) / n;
  d->offset_at_start_s = d->intercept_s + d->rate * d->overlap_start_s;
  d->offset_at_end_s = d->intercept_s + d->rate * d->overlap_end_s;
}

}  // namespace

DriftEstimate EstimateDrift(const TimedSamples& view, const TimedSamples& light, double offset_s,
                            double window_s, double max_lag_s, double min_confidence) {
  RELIT_CHECK(view.rate_hz == light.rate_hz && view.rate_hz > 0 && window_s > 0);
  const int rate = light.rate_hz;
  DriftEstimate d;
  d.overlap_start_s = std::max(light.start_s, view.start_s - offset_s);
  d.overlap_end_s = std::min(light.end_s(), view.end_s() - offset_s);
  const double span_s = d.overlap_end_s - d.overlap_start_s;
  if (span_s < 2.0) {
    d.reason = "the audio tracks overlap for less than 2 s";
    return d;
  }
  d.window_s = std::min(window_s, span_s / 2);
  const int count = std::clamp(static_cast<int>(span_s / d.window_s), 2, 8);
  const int64_t length = std::llround(d.window_s * rate);
  for (int i = 0; i < count; ++i) {
    const double centre_s =
        d.overlap_start_s + d.window_s / 2 + i * (span_s - d.window_s) / (count - 1);
    const double begin_s = centre_s - d.window_s / 2;
    double light_start_s = 0, view_start_s = 0;
    const std::vector<float> b =
        Slice(light, std::llround((begin_s - light.start_s) * rate), length, &light_start_s);
    const std::vector<float> a = Slice(
        view, std::llround((begin_s + offset_s - view.start_s) * rate), length, &view_start_s);
    LagEstimate lag;
    try {
      lag = GccPhatLag(a, b, rate, std::min(max_lag_s, d.window_s / 2), 0.005);
    } catch (const Error&) {
      continue;  // silent window
    }
    if (lag.confidence < min_confidence) continue;
    d.windows.push_back({centre_s, (view_start_s - light_start_s) + lag.lag_s, lag.confidence});
  }
  if (d.windows.size() < 2) {
    d.reason = "fewer than two windows with a clear match (quiet recording?)";
    return d;
  }
  FitLine(&d);
  d.valid = true;
  return d;
}

}  // namespace relit::capture
