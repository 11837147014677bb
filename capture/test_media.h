// Helpers for the capture tests: small videos made with the ffmpeg CLI
// (lavfi sources), temporary folders and reading capture.json back.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/capture_options.h"

namespace relit::capture::testing {

// Runs a shell command; throws relit::Error with its output on failure.
void Shell(const std::string& command);

// A fresh empty directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  explicit TempDir(const std::string& name);
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Room sound for sync tests: `seconds` of pink noise with a few sharp claps,
// as a 48 kHz mono WAV.
void MakeRoomSound(const std::string& wav, double seconds, int seed);

// An H.264 MP4 of moving test pattern (testsrc2, 160x120, 30 fps) lasting
// `seconds`, with audio samples [start_sample, start_sample + seconds*48k)
// of `wav` (none when `wav` is empty). `faststart` puts the index first.
void MakeVideo(const std::string& mp4, double seconds, const std::string& wav,
               int64_t start_sample, bool faststart = true);

// Room sound with claps at chosen times: `seconds` of pink noise (48 kHz mono
// WAV) with a 30 ms burst of loud white noise starting at each of clap_times_s.
void MakeClapRoomSound(const std::string& wav, double seconds, int seed,
                       const std::vector<double>& clap_times_s);

// One phone's recording of a room WAV (48 kHz), for sync tests. The phone
// starts at room time room_start_s; its audio is resampled to audio_rate_hz
// and encoded as AAC (with the encoder's priming), its video is testsrc2 at
// `fps` (e.g. "30000/1001") and `size`.
struct PhoneClip {
  double room_start_s = 0;
  double seconds = 4;
  std::string fps = "30";
  std::string size = "160x120";
  int audio_rate_hz = 48000;
  // Clock drift: the phone's clock runs fast by drift_extra_hz / 48000
  // (its 48 000 samples span 48000 / (48000 + drift_extra_hz) s of room time).
  int drift_extra_hz = 0;
  // Remuxed afterwards with the audio stream shifted this much later
  // (ffmpeg -itsoffset: a non-zero audio start time).
  double audio_delay_s = 0;
  // Remuxed afterwards with -ss cut_start_s -c copy: an MP4 edit list that
  // hides the first cut_start_s of the (still stored) audio.
  double cut_start_s = 0;
  // Container time of the sound at room time t: what sync must recover.
  double ContainerTime(double room_time_s) const {
    return (room_time_s - room_start_s) * (48000.0 + drift_extra_hz) / 48000.0 + audio_delay_s -
           cut_start_s;
  }
};
void MakePhoneClip(const std::string& mp4, const std::string& room_wav, const PhoneClip& clip);

// Options for a test run: inputs, output, and quiet logs.
CaptureOptions TestOptions(const std::string& view, const std::string& light, const std::string& out);

// capture.json of a finished run.
nlohmann::json ReadCaptureJson(const std::string& out);


}  // namespace relit::capture::testing
