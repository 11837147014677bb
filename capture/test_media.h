// Helpers for the capture tests: small videos made with the ffmpeg CLI
// (lavfi sources), temporary folders and reading capture.json back.
#pragma once

#include <filesystem>
#include <string>

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

// Options for a test run: inputs, output, and quiet logs.
CaptureOptions TestOptions(const std::string& view, const std::string& light, const std::string& out);

// capture.json of a finished run.
nlohmann::json ReadCaptureJson(const std::string& out);


}  // namespace relit::capture::testing
