#include "tools/synth/audio.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include <opencv2/core.hpp>

#include "core/atomic_output.h"
#include "core/error.h"
#include "tools/synth/trajectory.h"

namespace relit::synth {

RoomSound::RoomSound(const RoomSoundParams& params, double start_s, double end_s,
                     std::vector<double> clap_times_s, uint64_t seed)
    : params_(params), start_s_(start_s), clap_times_s_(std::move(clap_times_s)) {
  RELIT_REQUIRE(params_.sample_rate_hz >= 8000, "audio sample rate must be >= 8000 Hz, got ",
                params_.sample_rate_hz);
  RELIT_REQUIRE(end_s > start_s, "room sound needs a positive duration");
  const double fs = params_.sample_rate_hz;
  const int64_t count = static_cast<int64_t>(std::ceil((end_s - start_s) * fs)) + 2;
  room_.assign(count, 0.0f);
  uint64_t state = seed ^ 0x5eed0a0d10ULL;
  // Ambient: mostly low rumble (one-pole low-pass of white noise, ~200 Hz)
  // with a little broadband hiss. Normalised to the requested RMS below.
  const double pole = std::exp(-2.0 * M_PI * 200.0 / fs);
  double lowpassed = 0, sum_squares = 0;
  std::vector<double> ambient(count);
  for (int64_t n = 0; n < count; ++n) {
    const double white = NormalFromState(&state);
    lowpassed = pole * lowpassed + (1 - pole) * white;
    ambient[n] = 8.0 * lowpassed + 0.3 * white;
    sum_squares += ambient[n] * ambient[n];
  }
  const double scale = params_.room_noise_rms / std::sqrt(sum_squares / count + 1e-30);
  for (int64_t n = 0; n < count; ++n) room_[n] = static_cast<float>(scale * ambient[n]);
  // Claps: a noise burst with a 0.5 ms attack and an exponential decay.
  for (double clap_s : clap_times_s_) {
    RELIT_REQUIRE(clap_s >= start_s && clap_s <= end_s, "clap at ", clap_s,
                  " s lies outside the room sound [", start_s, ", ", end_s, "] s");
    const int64_t first = static_cast<int64_t>(std::ceil((clap_s - start_s) * fs));
    const int64_t length = static_cast<int64_t>(8 * params_.clap_decay_s * fs);
    for (int64_t k = 0; k < length && first + k < count; ++k) {
      const double t = (first + k) / fs + start_s - clap_s;  // >= 0
      const double envelope = (1 - std::exp(-t / 0.0005)) * std::exp(-t / params_.clap_decay_s);
      room_[first + k] += static_cast<float>(params_.clap_peak * envelope * 0.5 *
                                             NormalFromState(&state));
    }
  }
}

float RoomSound::RoomAt(double t_s) const {
  const double x = (t_s - start_s_) * params_.sample_rate_hz;
  RELIT_CHECK(x >= 0 && x <= static_cast<double>(room_.size() - 1));
  const int64_t i = std::min<int64_t>(static_cast<int64_t>(x), room_.size() - 2);
  const double f = x - i;
  return static_cast<float>((1 - f) * room_[i] + f * room_[i + 1]);
}

std::vector<float> RoomSound::Record(double recording_start_s, int64_t sample_count,
                                     double mic_gain, uint64_t mic_seed) const {
  return Record(recording_start_s, sample_count, params_.sample_rate_hz, mic_gain, mic_seed);
}

std::vector<float> RoomSound::Record(double recording_start_s, int64_t sample_count, int rate_hz,
                                     double mic_gain, uint64_t mic_seed) const {
  RELIT_CHECK(rate_hz > 0);
  std::vector<float> samples(sample_count);
  uint64_t state = mic_seed ^ 0x0303ab1eULL;
  for (int64_t n = 0; n < sample_count; ++n) {
    const double t = recording_start_s + static_cast<double>(n) / rate_hz;
    samples[n] = static_cast<float>(mic_gain * RoomAt(t) +
                                    params_.mic_noise_rms * NormalFromState(&state));
  }
  return samples;
}

std::vector<double> PickClapTimes(double begin_s, double end_s, int count, double min_gap_s,
                                  uint64_t seed) {
  RELIT_REQUIRE(end_s - begin_s >= (count - 1) * min_gap_s, "cannot fit ", count,
                " claps at least ", min_gap_s, " s apart into [", begin_s, ", ", end_s, "] s");
  // Evenly spread slots, each clap placed randomly within its slot.
  uint64_t state = seed ^ 0xc1a95ULL;
  std::vector<double> times;
  const double slot = (end_s - begin_s) / count;
  for (int k = 0; k < count; ++k) {
    const double usable = std::max(0.0, slot - min_gap_s);
    times.push_back(begin_s + k * slot + 0.5 * min_gap_s * (k > 0) +
                    usable * UniformFromState(&state));
  }
  return times;
}

void WriteWav(const std::string& path, const std::vector<float>& samples, int sample_rate_hz) {
  std::string data;
  auto put16 = [&data](uint16_t v) { data.push_back(char(v & 0xff)); data.push_back(char(v >> 8)); };
  auto put32 = [&](uint32_t v) { put16(v & 0xffff); put16(v >> 16); };
  const uint32_t bytes = static_cast<uint32_t>(samples.size() * 2);
  data += "RIFF";
  put32(36 + bytes);
  data += "WAVEfmt ";
  put32(16);
  put16(1);  // PCM
  put16(1);  // mono
  put32(sample_rate_hz);
  put32(sample_rate_hz * 2);
  put16(2);
  put16(16);
  data += "data";
  put32(bytes);
  for (float s : samples) {
    const double clipped = std::clamp(static_cast<double>(s), -1.0, 1.0);
    put16(static_cast<uint16_t>(static_cast<int16_t>(std::lround(clipped * 32767.0))));
  }
  AtomicWriteFile(path, data);
}

double CrossCorrelationLagS(const std::vector<float>& a, const std::vector<float>& b,
                            int sample_rate_hz, double max_lag_s) {
  RELIT_REQUIRE(!a.empty() && !b.empty(), "cross-correlation of an empty signal");
  const int n = cv::getOptimalDFTSize(static_cast<int>(a.size() + b.size()));
  cv::Mat fa = cv::Mat::zeros(1, n, CV_64F), fb = cv::Mat::zeros(1, n, CV_64F);
  for (size_t i = 0; i < a.size(); ++i) fa.at<double>(0, static_cast<int>(i)) = a[i];
  for (size_t i = 0; i < b.size(); ++i) fb.at<double>(0, static_cast<int>(i)) = b[i];
  cv::Mat spectrum_a, spectrum_b, product, correlation;
  cv::dft(fa, spectrum_a, cv::DFT_COMPLEX_OUTPUT);
  cv::dft(fb, spectrum_b, cv::DFT_COMPLEX_OUTPUT);
  cv::mulSpectrums(spectrum_a, spectrum_b, product, 0, /*conjB=*/true);
  cv::idft(product, correlation, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  // correlation[k] = sum_m a[m] b[m - k] (circular); negative lags wrap to n + k.
  const int max_lag = static_cast<int>(std::min<double>(max_lag_s * sample_rate_hz, n / 2 - 1));
  int best_lag = 0;
  double best = -1e300;
  for (int lag = -max_lag; lag <= max_lag; ++lag) {
    const double value = correlation.at<double>(0, lag >= 0 ? lag : n + lag);
    if (value > best) {
      best = value;
      best_lag = lag;
    }
  }
  // Parabolic refinement around the peak for sub-sample precision.
  double refined = best_lag;
  if (std::abs(best_lag) < max_lag) {
    const double left = correlation.at<double>(0, best_lag - 1 >= 0 ? best_lag - 1 : n + best_lag - 1);
    const double right = correlation.at<double>(0, best_lag + 1 >= 0 ? best_lag + 1 : n + best_lag + 1);
    const double denominator = left - 2 * best + right;
    if (denominator < 0) refined += 0.5 * (left - right) / denominator;
  }
  return refined / sample_rate_hz;
}

}  // namespace relit::synth
