#include "capture/video_io.h"

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/error.h"

namespace relit::capture {

namespace {

namespace fs = std::filesystem;

std::string TempLogPath() {
  static std::atomic<int> counter{0};
  return (fs::temp_directory_path() /
          ("relit-capture-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".log"))
      .string();
}

std::string ReadAndRemove(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::error_code ignored;
  fs::remove(path, ignored);
  return buffer.str();
}

// The last meaningful line of an ffmpeg/ffprobe log, for one-line messages.
std::string LastLine(const std::string& text) {
  std::istringstream lines(text);
  std::string line, last;
  while (std::getline(lines, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  if (last.size() > 300) last = last.substr(0, 300) + "...";
  return last;
}



bool IsErrorLine(const std::string& line) {
  return line.find("] [error] ") != std::string::npos ||
         line.find("] [fatal] ") != std::string::npos ||
         line.find("] [panic] ") != std::string::npos;
}

// Reads the number after `key` in `line`; false when absent.
bool NumberAfter(const std::string& line, const std::string& key, double* value) {
  const size_t at = line.find(key);
  if (at == std::string::npos) return false;
  const char* text = line.c_str() + at + key.size();
  char* end = nullptr;
  *value = std::strtod(text, &end);
  return end != text && std::isfinite(*value);
}

// Frame times from (a)showinfo lines, and the first error line. Times are
// computed from the integer pts and the filter's time base (pts_time is
// printed with only 6 significant digits).
void ParseShowinfoLog(const std::string& log, const std::string& path, std::vector<double>* times,
                      DecodeIssue* issue) {
  std::istringstream lines(log);
  std::string line;
  double tb_num = 0, tb_den = 0;
  while (std::getline(lines, line)) {
    if (line.find("showinfo_") != std::string::npos) {
      const size_t config = line.find("config in time_base: ");
      if (config != std::string::npos) {
        std::sscanf(line.c_str() + config + 21, "%lf/%lf", &tb_num, &tb_den);
        continue;
      }
      if (line.find(" n:") == std::string::npos) continue;
      double pts = 0, rate = 0, t = 0;
      bool ok = NumberAfter(line, " pts:", &pts);
      if (ok && tb_num > 0 && tb_den > 0) {
        t = pts * tb_num / tb_den;
      } else if (ok && NumberAfter(line, " rate:", &rate) && rate > 0) {
        t = pts / rate;  // audio filters run at a time base of 1 / sample rate
      } else {
        ok = NumberAfter(line, "pts_time:", &t);
      }
      RELIT_REQUIRE(ok, path, ": frame ", times->size(), " has no presentation timestamp; remux "
                    "the file (ffmpeg -i IN -c copy OUT.mp4)");
      times->push_back(t);
    } else if (IsErrorLine(line) && !issue->found) {
      issue->found = true;
      issue->frames_before = static_cast<int>(times->size());
      issue->time_s = times->empty() ? 0.0 : times->back();
      const size_t level = line.find("] [");
      const size_t text = line.find("] ", level + 2);
      issue->message = text == std::string::npos ? line : line.substr(text + 2);
    }
  }
}

int ParseBitDepth(const nlohmann::json& stream) {
  const std::string bits = stream.value("bits_per_raw_sample", std::string());
  if (!bits.empty() && std::isdigit(static_cast<unsigned char>(bits[0]))) return std::stoi(bits);
  const std::string pix = stream.value("pix_fmt", std::string());
  for (int depth : {16, 14, 12, 10, 9}) {
    if (pix.find("p" + std::to_string(depth)) != std::string::npos) return depth;
  }
  return 8;
}

std::string ColorMatrix(const VideoInfo& info) {
  const std::string& s = info.color_space;
  if (s == "smpte170m" || s == "bt470bg") return "bt601";
  if (s == "bt2020nc" || s == "bt2020c") return "bt2020";
  if (s == "smpte240m") return "smpte240m";
  return "bt709";  // tagged bt709, or untagged: what phones record
}

std::string RotationFilter(int rotation_deg) {
  switch (rotation_deg) {
    case 90: return "transpose=clock,";
    case 180: return "hflip,vflip,";
    case 270: return "transpose=cclock,";
    default: return "";
  }
}

}  // namespace

VideoInfo ProbeVideo(const std::string& path, const std::string& role) {
  std::error_code error;
  RELIT_REQUIRE(fs::exists(path, error), "cannot read the ", role, " ", path,
                ": no such file; check the path");
  RELIT_REQUIRE(fs::is_regular_file(path, error), "cannot read the ", role, " ", path,
                ": not a regular file");
  RELIT_REQUIRE(std::ifstream(path).good(), "cannot read the ", role, " ", path,
                ": permission denied or unreadable");
  const CommandResult probe = RunCommand("ffprobe -v error -print_format json -show_streams "
                                         "-show_format " + ShellQuote(path));
  RELIT_REQUIRE(probe.status == 0, "cannot read the ", role, " ", path,
                ": the file is truncated or not a video (ffprobe ", ExitDescription(probe.status),
                ": ", LastLine(probe.err), "); copy it from the phone again");
  const nlohmann::json j = nlohmann::json::parse(probe.out, nullptr, false);
  RELIT_REQUIRE(!j.is_discarded() && j.contains("streams"), "cannot read the ", role, " ", path,
                ": ffprobe gave no stream list");
  VideoInfo info;
  info.path = path;
  info.role = role;
  if (j.contains("format")) info.container = j["format"].value("format_name", "");
  bool found_video = false;
  for (const auto& stream : j["streams"]) {
    const std::string type = stream.value("codec_type", "");
    const bool cover_art = stream.contains("disposition") &&
                           stream["disposition"].value("attached_pic", 0) != 0;
    if (type == "video" && !found_video && !cover_art) {
      found_video = true;
      info.codec = stream.value("codec_name", "");
      info.pix_fmt = stream.value("pix_fmt", "");
      info.coded_width_px = stream.value("width", 0);
      info.coded_height_px = stream.value("height", 0);
      info.color_transfer = stream.value("color_transfer", "");
      info.color_space = stream.value("color_space", "");
      info.color_range = stream.value("color_range", "");
      info.color_primaries = stream.value("color_primaries", "");
      info.bit_depth = ParseBitDepth(stream);
      info.header_frame_count = std::atoll(stream.value("nb_frames", std::string("0")).c_str());
      info.duration_s = std::atof(stream.value("duration", std::string("0")).c_str());
      if (stream.contains("tags") && stream["tags"].contains("rotate")) {
        info.rotation_deg = std::atoi(stream["tags"]["rotate"].get<std::string>().c_str());
      } else if (stream.contains("side_data_list")) {
        for (const auto& side : stream["side_data_list"]) {
          // The display matrix angle is counter-clockwise; "rotate" is clockwise.
          if (side.contains("rotation")) info.rotation_deg = -side["rotation"].get<int>();
        }
      }
      info.rotation_deg = ((info.rotation_deg % 360) + 360) % 360;
    } else if (type == "audio" && !info.has_audio) {
      info.has_audio = true;
      info.audio_sample_rate_hz = std::atoi(stream.value("sample_rate", std::string("0")).c_str());
    }
  }
  RELIT_REQUIRE(found_video && info.coded_width_px > 0 && info.coded_height_px > 0, "the ", role,
                " ", path, " has no video stream; pass a video file recorded by the phone");
  RELIT_REQUIRE(info.rotation_deg % 90 == 0, "the ", role, " ", path, " has a display rotation of ",
                info.rotation_deg, " degrees; only multiples of 90 are supported");
  const bool swap = info.rotation_deg == 90 || info.rotation_deg == 270;
  info.width_px = swap ? info.coded_height_px : info.coded_width_px;
  info.height_px = swap ? info.coded_width_px : info.coded_height_px;
  if (info.duration_s <= 0 && j.contains("format")) {
    info.duration_s = std::atof(j["format"].value("duration", std::string("0")).c_str());
  }
  return info;
}

AnalysisPass AnalyseVideo(const VideoInfo& info, int max_width_px,
                          const std::function<void(int, const cv::Mat&)>& on_frame) {
  const int width = std::min(max_width_px, info.coded_width_px);
  const int height = std::max(
      1, static_cast<int>(std::lround(static_cast<double>(info.coded_height_px) * width /
                                      info.coded_width_px)));
  const std::string log = TempLogPath();
  const std::string command =
      "ffmpeg -nostdin -hide_banner -nostats -loglevel level+info -copyts -noautorotate -i " +
      ShellQuote(info.path) + " -map 0:v:0 -fps_mode passthrough -vf showinfo=checksum=0,scale=" +
      std::to_string(width) + ":" + std::to_string(height) +
      ":flags=area,format=gray -f rawvideo pipe:1 2>" + ShellQuote(log);
  FILE* pipe = ::popen(command.c_str(), "r");
  RELIT_REQUIRE(pipe != nullptr, "cannot start ffmpeg to decode ", info.path);
  cv::Mat grey(height, width, CV_8UC1);
  const size_t frame_bytes = static_cast<size_t>(width) * height;
  int frames = 0;
  size_t got = 0;
  while ((got = std::fread(grey.data, 1, frame_bytes, pipe)) == frame_bytes) {
    on_frame(frames++, grey);
  }
  const int status = ::pclose(pipe);
  const std::string text = ReadAndRemove(log);
  AnalysisPass pass;
  ParseShowinfoLog(text, info.path, &pass.times_s, &pass.issue);
  if (!pass.issue.found && (status != 0 || got != 0)) {
    pass.issue = {true, frames, frames > 0 ? pass.times_s.at(frames - 1) : 0.0,
                  "ffmpeg " + ExitDescription(status) + ": " + LastLine(text)};
  }
  // A frame's showinfo line is written before its pixels reach the pipe.
  pass.times_s.resize(std::min<size_t>(pass.times_s.size(), frames));
  RELIT_REQUIRE(static_cast<int>(pass.times_s.size()) == frames, "decoding the ", info.role, " ",
                info.path, ": got ", frames, " frames but ", pass.times_s.size(), " timestamps");
  pass.issue.frames_before = std::min(pass.issue.frames_before, frames);
  if (!pass.issue.found && info.header_frame_count > 0 && frames < info.header_frame_count) {
    spdlog::warn("{}: decoded {} frames, the container lists {} (edit list?)", info.path, frames,
                 info.header_frame_count);
  }
  return pass;
}

FrameReader::FrameReader(const VideoInfo& info) : info_(info), log_path_(TempLogPath()) {
  const std::string range = info.color_range == "pc" || info.pix_fmt.rfind("yuvj", 0) == 0 ? "pc" : "tv";
  // Full-precision YUV -> RGB with the stream's own matrix and range; 16-bit
  // output keeps 10-bit video intact.
  const std::string command =
      "ffmpeg -nostdin -hide_banner -nostats -loglevel error -copyts -noautorotate -i " +
      ShellQuote(info.path) + " -map 0:v:0 -fps_mode passthrough -vf " +
      RotationFilter(info.rotation_deg) + "scale=in_color_matrix=" + ColorMatrix(info) +
      ":in_range=" + range + ":out_range=pc:flags=accurate_rnd+full_chroma_int+bitexact" +
      ",format=rgb48le -f rawvideo pipe:1 2>" + ShellQuote(log_path_);
  pipe_ = ::popen(command.c_str(), "r");
  RELIT_REQUIRE(pipe_ != nullptr, "cannot start ffmpeg to decode ", info.path);
}

FrameReader::~FrameReader() { Close(); }

bool FrameReader::Next(cv::Mat* rgb16) {
  RELIT_CHECK(pipe_ != nullptr);
  rgb16->create(info_.height_px, info_.width_px, CV_16UC3);
  const size_t bytes = static_cast<size_t>(info_.width_px) * info_.height_px * 6;
  const size_t got = std::fread(rgb16->data, 1, bytes, pipe_);
  if (got == 0) return false;
  RELIT_REQUIRE(got == bytes, "decoding the ", info_.role, " ", info_.path,
                ": the stream ended inside frame ", index_ + 1);
  ++index_;
  return true;
}

void FrameReader::Close() {
  if (pipe_ == nullptr) return;
  ::pclose(pipe_);  // an early close makes ffmpeg stop on a broken pipe: expected
  pipe_ = nullptr;
  std::error_code ignored;
  fs::remove(log_path_, ignored);
}

namespace {

double JsonSeconds(const nlohmann::json& object, const char* key, double fallback) {
  if (!object.contains(key) || !object[key].is_string()) return fallback;
  const std::string text = object[key].get<std::string>();
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  return end != text.c_str() && std::isfinite(value) ? value : fallback;
}

// Presentation time of the first audio frame out of the decoder, from the
// first ashowinfo line of a decode of that one frame.
double FirstDecodedAudioTime(const VideoInfo& info) {
  const CommandResult result = RunCommand(
      "ffmpeg -nostdin -hide_banner -nostats -loglevel level+info -copyts -i " +
      ShellQuote(info.path) + " -map 0:a:0 -af ashowinfo -frames:a 1 -f null -");
  std::vector<double> times;
  DecodeIssue issue;
  ParseShowinfoLog(result.err, info.path, &times, &issue);
  RELIT_REQUIRE(result.ok() && !times.empty(), "cannot decode the audio of the ", info.role, " ",
                info.path, ": ffmpeg ", ExitDescription(result.status), ": ", LastLine(result.err),
                "; remux it (ffmpeg -i IN -c copy OUT.mp4) or pass --offset-s SECONDS");
  return times.front();
}

}  // namespace

AudioStart ProbeAudioStart(const VideoInfo& info) {
  RELIT_CHECK(info.has_audio);
  const CommandResult probe = RunCommand(
      "ffprobe -v error -select_streams a:0 -show_entries stream=start_time:packet=pts_time "
      "-read_intervals %+#1 -show_packets -print_format json " + ShellQuote(info.path));
  const nlohmann::json j = nlohmann::json::parse(probe.out, nullptr, false);
  RELIT_REQUIRE(probe.ok() && !j.is_discarded(), "cannot read the audio timestamps of the ",
                info.role, " ", info.path, ": ffprobe ", ExitDescription(probe.status), ": ",
                LastLine(probe.err), "; remux it (ffmpeg -i IN -c copy OUT.mp4)");
  AudioStart start;
  start.decoded_s = FirstDecodedAudioTime(info);
  start.stream_s = start.decoded_s;
  if (j.contains("streams") && !j["streams"].empty()) {
    start.stream_s = JsonSeconds(j["streams"][0], "start_time", start.decoded_s);
  }
  start.first_packet_s = start.stream_s;
  if (j.contains("packets") && !j["packets"].empty()) {
    start.first_packet_s = JsonSeconds(j["packets"][0], "pts_time", start.stream_s);
  }
  return start;
}

AudioTrack DecodeAudio(const VideoInfo& info, int sample_rate_hz) {
  RELIT_CHECK(info.has_audio);
  const AudioStart start = ProbeAudioStart(info);
  // Raw samples in decoding order: no padding or trimming to timestamps, so
  // samples[n] is at start.decoded_s + n / rate (the resampler keeps time 0).
  const CommandResult result = RunCommand(
      "ffmpeg -nostdin -hide_banner -nostats -loglevel error -copyts -i " +
      ShellQuote(info.path) + " -map 0:a:0 -ac 1 -ar " + std::to_string(sample_rate_hz) +
      " -f f32le pipe:1");
  RELIT_REQUIRE(result.ok() && !result.out.empty(), "cannot decode the audio of the ", info.role,
                " ", info.path, ": ffmpeg ", ExitDescription(result.status), ": ",
                LastLine(result.err), "; remux it (ffmpeg -i IN -c copy OUT.mp4) or pass "
                "--offset-s SECONDS");
  if (!result.err.empty()) spdlog::warn("{}: audio decoding: {}", info.path, LastLine(result.err));
  if (std::abs(start.decoded_s - start.stream_s) > 0.5e-3) {
    spdlog::warn("{}: the first decoded audio sample is at {:.6f} s but the stream start_time is "
                 "{:.6f} s; using the decoded time", info.path, start.decoded_s, start.stream_s);
  }
  AudioTrack track;
  track.sample_rate_hz = sample_rate_hz;
  track.start_s = start.decoded_s;
  track.stream_start_s = start.stream_s;
  track.first_packet_pts_s = start.first_packet_s;
  track.samples.resize(result.out.size() / sizeof(float));
  std::memcpy(track.samples.data(), result.out.data(), track.samples.size() * sizeof(float));
  return track;
}

FileFingerprint Fingerprint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  RELIT_REQUIRE(in.good(), "cannot read ", path);
  uint64_t hash = 0xcbf29ce484222325ull;
  FileFingerprint print;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const std::streamsize n = in.gcount();
    for (std::streamsize i = 0; i < n; ++i) {
      hash = (hash ^ static_cast<uint8_t>(buffer[i])) * 0x100000001b3ull;
    }
    print.size_bytes += static_cast<uint64_t>(n);
  }
  char hex[17];
  std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(hash));
  print.fnv1a64 = hex;
  return print;
}

}  // namespace relit::capture
