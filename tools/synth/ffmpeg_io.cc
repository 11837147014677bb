#include "tools/synth/ffmpeg_io.h"

#include <csignal>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/error.h"

namespace relit::synth {

namespace {

std::string ReadTail(const std::string& path, size_t max_chars = 600) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (text.size() > max_chars) text = "..." + text.substr(text.size() - max_chars);
  for (char& c : text) {
    if (c == '\n') c = ' ';
  }
  return text;
}


// Runs a command reading its whole stdout; throws with stderr on failure.
std::string RunCapture(const std::string& command, const std::string& what) {
  const CommandResult result = RunCommand(command);
  RELIT_REQUIRE(result.ok(), what, ": ", command.substr(0, command.find(' ')), " ", ExitDescription(result.status),
                ": ", result.ErrTail(600));
  return result.out;
}

// 30 -> "30", 30000/1001 -> "30000/1001", 24.5 -> "49/2"-style via 1/1000.
std::string FpsRational(double fps) {
  const double ntsc = fps * 1.001;
  if (std::abs(fps - std::round(fps)) < 1e-9) return std::to_string(std::lround(fps));
  if (std::abs(ntsc - std::round(ntsc)) < 1e-6) return std::to_string(std::lround(ntsc) * 1000) + "/1001";
  return std::to_string(std::lround(fps * 1000)) + "/1000";
}

}  // namespace

void VideoEncodeParams::Check() const {
  RELIT_REQUIRE(width_px > 0 && height_px > 0 && width_px % 2 == 0 && height_px % 2 == 0,
                "video size must be positive and even (yuv420p), got ", width_px, "x", height_px);
  RELIT_REQUIRE(fps > 0 && fps <= 240, "video fps must be in (0, 240], got ", fps);
  RELIT_REQUIRE(crf >= 0 && crf <= 51, "x264 crf must be in [0, 51], got ", crf);
  RELIT_REQUIRE(display_rotation_deg == 0 || display_rotation_deg == 90 ||
                    display_rotation_deg == 180 || display_rotation_deg == 270,
                "display rotation must be 0, 90, 180 or 270 degrees, got ", display_rotation_deg);
  RELIT_REQUIRE(std::abs(audio_start_s) <= 0.5, "audio start must be within 0.5 s of the first frame, got ",
                audio_start_s);
}

VideoEncoder::VideoEncoder(const std::string& output_mp4, const VideoEncodeParams& params)
    : output_(output_mp4), log_path_(output_mp4 + ".ffmpeg.log"), params_(params) {
  params_.Check();
  // A dying ffmpeg must surface as an error from Finish(), not kill us.
  std::signal(SIGPIPE, SIG_IGN);
  std::ostringstream cmd;
  cmd << "ffmpeg -nostdin -y -hide_banner -loglevel error"
      << " -f rawvideo -pix_fmt rgb24 -s " << params_.width_px << "x" << params_.height_px
      << " -framerate " << FpsRational(params_.fps) << " -i -";
  if (!params_.audio_wav.empty()) {
    // Audio after the first frame: delayed here. Audio before it: Finish()
    // delays the video instead (an input offset on raw frames would be
    // rounded to whole frames, and -r would fill the gap with a copy).
    if (params_.audio_start_s > 0) cmd << " -itsoffset " << params_.audio_start_s;
    cmd << " -i " << ShellQuote(params_.audio_wav);
  }
  cmd << " -map 0:v:0";
  if (!params_.audio_wav.empty()) cmd << " -map 1:a:0";
  // RGB -> BT.709 limited-range YUV, tagged as such with the sRGB transfer.
  cmd << " -vf scale=out_color_matrix=bt709:out_range=tv"
      << " -c:v libx264 -preset " << params_.x264_preset << " -crf " << params_.crf
      << " -pix_fmt yuv420p -r " << FpsRational(params_.fps)
      << " -color_primaries bt709 -color_trc iec61966-2-1 -colorspace bt709 -color_range tv";
  if (!params_.audio_wav.empty()) cmd << " -c:a aac -b:a 192k -ar " << params_.audio_rate_hz;
  // ffmpeg 5.1 drops "rotate" when encoding; Finish() adds it by remuxing.
  const bool remux = params_.display_rotation_deg != 0 || params_.audio_start_s < 0;
  encoded_ = remux ? output_ + ".encoded.mp4" : output_;
  cmd << " -movflags +faststart -f mp4 " << ShellQuote(encoded_) << " 2>" << ShellQuote(log_path_);
  pipe_ = ::popen(cmd.str().c_str(), "w");
  RELIT_REQUIRE(pipe_ != nullptr, "cannot start ffmpeg to write ", output_);
}

VideoEncoder::~VideoEncoder() {
  if (pipe_ != nullptr) {
    ::pclose(pipe_);
    std::error_code ignored;
    std::filesystem::remove(log_path_, ignored);
  }
}

void VideoEncoder::AddFrame(const std::vector<uint8_t>& rgb) {
  RELIT_CHECK(pipe_ != nullptr);
  RELIT_CHECK(rgb.size() == static_cast<size_t>(params_.width_px) * params_.height_px * 3);
  if (std::fwrite(rgb.data(), 1, rgb.size(), pipe_) != rgb.size()) {
    const int status = ::pclose(pipe_);
    pipe_ = nullptr;
    Fail("writing ", output_, ": ffmpeg ", ExitDescription(status), ": ", ReadTail(log_path_));
  }
  ++frames_;
}

void VideoEncoder::Finish() {
  RELIT_CHECK(pipe_ != nullptr);
  const int status = ::pclose(pipe_);
  pipe_ = nullptr;
  const std::string message = ReadTail(log_path_);
  std::error_code ignored;
  std::filesystem::remove(log_path_, ignored);
  RELIT_REQUIRE(status == 0, "encoding ", output_, ": ffmpeg ", ExitDescription(status), ": ",
                message);
  if (encoded_ != output_) {
    // Stream copy: the video delayed by -audio_start_s (an edit list, as
    // phones write) and the rotation. ffmpeg 5.1 stores a "rotate" tag as a
    // counter-clockwise display matrix angle (players turn the frames
    // counter-clockwise by it): a clockwise rotation r is written as 360 - r
    // (ffmpeg_io_test checks what players show).
    const std::string video_delay =
        params_.audio_start_s < 0 ? " -itsoffset " + std::to_string(-params_.audio_start_s) : "";
    RunCapture("ffmpeg -nostdin -y -v error -i " + ShellQuote(encoded_) + video_delay + " -i " +
                   ShellQuote(encoded_) + " -map 1:v -map 0:a? -c copy" +
                   (params_.display_rotation_deg != 0
                        ? " -metadata:s:v:0 rotate=" + std::to_string((360 - params_.display_rotation_deg) % 360)
                        : std::string()) +
                   " -movflags +faststart -f mp4 " +
                   ShellQuote(output_),
               "remuxing " + output_ + " (rotation metadata, audio start)");
    std::filesystem::remove(encoded_);
  }
}

MediaInfo ProbeMedia(const std::string& path) {
  RELIT_REQUIRE(std::filesystem::exists(path), "no such video file: ", path);
  const std::string text = RunCapture(
      "ffprobe -v error -count_frames -print_format json -show_streams " + ShellQuote(path),
      "probing " + path);
  const nlohmann::json probe = nlohmann::json::parse(text);
  MediaInfo info;
  for (const auto& stream : probe.at("streams")) {
    const std::string type = stream.value("codec_type", "");
    if (type == "video" && info.width_px == 0) {
      info.width_px = stream.value("width", 0);
      info.height_px = stream.value("height", 0);
      info.video_codec = stream.value("codec_name", "");
      info.pix_fmt = stream.value("pix_fmt", "");
      info.color_transfer = stream.value("color_transfer", "");
      info.frame_count = std::stoi(stream.value("nb_read_frames", std::string("0")));
      info.video_start_s = std::stod(stream.value("start_time", std::string("0")));
      const std::string rate = stream.value("r_frame_rate", std::string("0/1"));
      const size_t slash = rate.find('/');
      info.fps = std::stod(rate.substr(0, slash)) / std::stod(rate.substr(slash + 1));
      if (stream.contains("tags") && stream["tags"].contains("rotate")) {
        info.rotation_deg = std::stoi(stream["tags"]["rotate"].get<std::string>());
      } else if (stream.contains("side_data_list")) {
        for (const auto& side : stream["side_data_list"]) {
          // The display matrix angle is counter-clockwise; rotation_deg is clockwise.
          if (side.contains("rotation")) {
            info.rotation_deg = ((-side["rotation"].get<int>()) % 360 + 360) % 360;
          }
        }
      }
    } else if (type == "audio" && info.audio_sample_rate_hz == 0) {
      info.audio_sample_rate_hz = std::stoi(stream.value("sample_rate", std::string("0")));
      info.audio_start_s = std::stod(stream.value("start_time", std::string("0")));
    }
  }
  RELIT_REQUIRE(info.width_px > 0, path, " has no video stream");
  return info;
}

DecodedVideo DecodeVideo(const std::string& path, bool grey) {
  const MediaInfo info = ProbeMedia(path);
  DecodedVideo video;
  video.width_px = info.width_px;
  video.height_px = info.height_px;
  video.channels = grey ? 1 : 3;
  const std::string bytes = RunCapture(
      "ffmpeg -nostdin -v error -noautorotate -i " + ShellQuote(path) +
          " -map 0:v:0 -fps_mode passthrough -vf scale=in_color_matrix=bt709:in_range=tv:out_range=pc -f rawvideo -pix_fmt " +
          (grey ? "gray" : "rgb24") + " -",
      "decoding " + path);
  const size_t frame_bytes = static_cast<size_t>(video.width_px) * video.height_px * video.channels;
  RELIT_REQUIRE(bytes.size() % frame_bytes == 0, "decoding ", path, ": got ", bytes.size(),
                " bytes, not a whole number of ", video.width_px, "x", video.height_px, " frames");
  for (size_t offset = 0; offset < bytes.size(); offset += frame_bytes) {
    video.frames.emplace_back(bytes.begin() + offset, bytes.begin() + offset + frame_bytes);
  }
  return video;
}

std::vector<float> DecodeAudio(const std::string& path, int sample_rate_hz) {
  RELIT_REQUIRE(std::filesystem::exists(path), "no such media file: ", path);
  const std::string bytes =
      RunCapture("ffmpeg -nostdin -v error -i " + ShellQuote(path) + " -map 0:a:0 -ac 1 -ar " +
                     std::to_string(sample_rate_hz) + " -f f32le -",
                 "decoding the audio of " + path);
  std::vector<float> samples(bytes.size() / sizeof(float));
  std::memcpy(samples.data(), bytes.data(), samples.size() * sizeof(float));
  return samples;
}

}  // namespace relit::synth
