#include "capture/test_media.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "capture/capture.h"
#include "capture/video_io.h"
#include "core/error.h"
#include "core/json_file.h"

namespace relit::capture::testing {

namespace fs = std::filesystem;

void Shell(const std::string& command) {
  const std::string full = command + " 2>&1";
  FILE* pipe = ::popen(full.c_str(), "r");
  RELIT_REQUIRE(pipe != nullptr, "cannot run: ", command);
  std::string output;
  char buffer[4096];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) output.append(buffer, n);
  const int status = ::pclose(pipe);
  RELIT_REQUIRE(status == 0, "command failed: ", command, "\n", output);
}

TempDir::TempDir(const std::string& name)
    : path_(fs::temp_directory_path() /
            ("relit-capture-test-" + name + "-" + std::to_string(::getpid()))) {
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

void MakeRoomSound(const std::string& wav, double seconds, int seed) {
  // Pink noise plus three short bursts of loud white noise (claps).
  Shell("ffmpeg -nostdin -v error -y -f lavfi -i anoisesrc=d=" + std::to_string(seconds) +
        ":c=pink:r=48000:a=0.05:seed=" + std::to_string(seed) +
        " -f lavfi -i anoisesrc=d=" + std::to_string(seconds) + ":c=white:r=48000:a=0.8:seed=" +
        std::to_string(seed + 100) +
        " -filter_complex \"[1]volume='if(lt(mod(t,1.7),0.03),1,0)':eval=frame[c];"
        "[0][c]amix=inputs=2:normalize=0\" -ac 1 -c:a pcm_s16le " + ShellQuote(wav));
}

void MakeVideo(const std::string& mp4, double seconds, const std::string& wav,
               int64_t start_sample, bool faststart) {
  std::string command = "ffmpeg -nostdin -v error -y -f lavfi -i testsrc2=size=160x120:rate=30:d=" +
                        std::to_string(seconds);
  if (!wav.empty()) command += " -i " + ShellQuote(wav);
  command += " -map 0:v";
  if (!wav.empty()) {
    command += " -map 1:a -af atrim=start_sample=" + std::to_string(start_sample) +
               ":end_sample=" + std::to_string(start_sample + static_cast<int64_t>(seconds * 48000)) +
               ",asetpts=N/SR/TB -c:a aac -b:a 128k";
  }
  command += " -c:v libx264 -crf 18 -pix_fmt yuv420p";
  if (faststart) command += " -movflags +faststart";
  Shell(command + " " + ShellQuote(mp4));
}

void MakeClapRoomSound(const std::string& wav, double seconds, int seed,
                       const std::vector<double>& clap_times_s) {
  std::string gate = "0";
  for (double t : clap_times_s) {
    gate += "+between(t," + std::to_string(t) + "," + std::to_string(t + 0.03) + ")";
  }
  Shell("ffmpeg -nostdin -v error -y -f lavfi -i anoisesrc=d=" + std::to_string(seconds) +
        ":c=pink:r=48000:a=0.05:seed=" + std::to_string(seed) +
        " -f lavfi -i anoisesrc=d=" + std::to_string(seconds) + ":c=white:r=48000:a=0.8:seed=" +
        std::to_string(seed + 100) + " -filter_complex \"[1]volume='" + gate +
        "':eval=frame[c];[0][c]amix=inputs=2:normalize=0\" -ac 1 -c:a pcm_s16le " +
        ShellQuote(wav));
}

void MakePhoneClip(const std::string& mp4, const std::string& room_wav, const PhoneClip& clip) {
  const int room_rate_hz = 48000 + clip.drift_extra_hz;
  const int64_t first = std::llround(clip.room_start_s * room_rate_hz);
  const int64_t count = std::llround(clip.seconds * 48000);
  // Resampling the room to 48000 + extra Hz and calling it 48000 Hz makes
  // the phone's clock run fast by extra / 48000.
  std::string audio = "aresample=" + std::to_string(room_rate_hz) + ",asetrate=48000,atrim=" +
                      "start_sample=" + std::to_string(first) + ":end_sample=" +
                      std::to_string(first + count) + ",asetpts=N/SR/TB,aresample=" +
                      std::to_string(clip.audio_rate_hz);
  const bool remux = clip.audio_delay_s != 0 || clip.cut_start_s != 0;
  const std::string encoded = remux ? mp4 + ".encoded.mp4" : mp4;
  Shell("ffmpeg -nostdin -v error -y -f lavfi -i testsrc2=size=" + clip.size + ":rate=" +
        clip.fps + ":d=" + std::to_string(clip.seconds) + " -i " + ShellQuote(room_wav) +
        " -map 0:v -map 1:a -af " + audio + " -c:a aac -b:a 128k -ar " +
        std::to_string(clip.audio_rate_hz) + " -c:v libx264 -preset ultrafast -crf 23 "
        "-pix_fmt yuv420p -movflags +faststart " + ShellQuote(encoded));
  if (clip.audio_delay_s != 0) {
    Shell("ffmpeg -nostdin -v error -y -i " + ShellQuote(encoded) + " -itsoffset " +
          std::to_string(clip.audio_delay_s) + " -i " + ShellQuote(encoded) +
          " -map 0:v -map 1:a -c copy -movflags +faststart " + ShellQuote(mp4));
  } else if (clip.cut_start_s != 0) {
    Shell("ffmpeg -nostdin -v error -y -ss " + std::to_string(clip.cut_start_s) + " -i " +
          ShellQuote(encoded) + " -map 0 -c copy -movflags +faststart " + ShellQuote(mp4));
  }
  if (remux) fs::remove(encoded);
}

CaptureOptions TestOptions(const std::string& view, const std::string& light, const std::string& out) {
  CaptureOptions o;
  o.view = view;
  o.light = light;
  o.out = out;
  o.log_level = "warn";
  return o;
}

nlohmann::json ReadCaptureJson(const std::string& out) {
  return ReadJsonFile(out + "/capture.json", kCaptureKind, kCaptureVersion);
}

}  // namespace relit::capture::testing
