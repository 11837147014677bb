// Room sound recorded by two (or more) phones (relit-synth).
//
// One shared "room" signal on the common clock (low-level coloured noise
// plus a few sharp hand claps) is sampled by every phone over its own
// recording interval, multiplied by a per-phone microphone gain, plus
// independent microphone noise. A phone whose recording starts at common
// time t0 records sample n at common time t0 + n / sample_rate.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace relit::synth {

struct RoomSoundParams {
  int sample_rate_hz = 48000;
  double room_noise_rms = 0.01;   // shared ambient noise (full scale = 1)
  double clap_peak = 0.6;         // peak amplitude of a clap
  double clap_decay_s = 0.012;    // exponential decay time of a clap
  double mic_noise_rms = 0.004;   // independent noise per recording
};

class RoomSound {
 public:
  // The room signal covers common times [start_s, end_s]; `clap_times_s`
  // (common clock) must lie inside.
  RoomSound(const RoomSoundParams& params, double start_s, double end_s,
            std::vector<double> clap_times_s, uint64_t seed);

  // Samples recorded by a phone whose recording starts at common time
  // `recording_start_s` and lasts `sample_count` samples.
  std::vector<float> Record(double recording_start_s, int64_t sample_count, double mic_gain,
                            uint64_t mic_seed) const;
  // The same at another sample rate (the room signal is interpolated).
  std::vector<float> Record(double recording_start_s, int64_t sample_count, int rate_hz,
                            double mic_gain, uint64_t mic_seed) const;

  const std::vector<double>& clap_times_s() const { return clap_times_s_; }
  int sample_rate_hz() const { return params_.sample_rate_hz; }

 private:
  float RoomAt(double t_s) const;  // linear interpolation of the room signal

  RoomSoundParams params_;
  double start_s_;
  std::vector<float> room_;
  std::vector<double> clap_times_s_;
};

// Picks `count` clap times inside [begin_s, end_s], at least `min_gap_s` apart.
std::vector<double> PickClapTimes(double begin_s, double end_s, int count, double min_gap_s,
                                  uint64_t seed);

// Writes mono 16-bit PCM WAV (samples clipped to [-1, 1]).
void WriteWav(const std::string& path, const std::vector<float>& samples, int sample_rate_hz);

// Lag (seconds) that maximises the cross-correlation sum_n a[n] b[n - lag]:
// if `a` recorded the same sound as `b` but started `d` seconds earlier, the
// result is +d. Searches |lag| <= max_lag_s; computed with an FFT.
double CrossCorrelationLagS(const std::vector<float>& a, const std::vector<float>& b,
                            int sample_rate_hz, double max_lag_s);

}  // namespace relit::synth
