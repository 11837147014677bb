// Video and audio through the ffmpeg command-line tool (relit-synth and its
// tests). Frames travel as raw RGB through a pipe; nothing is linked against
// libav*.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>
#include "core/shell.h"

namespace relit::synth {

struct VideoEncodeParams {
  int width_px = 0;
  int height_px = 0;
  double fps = 30;                 // exact: 30000/1001 is written as such
  int audio_rate_hz = 48000;
  double audio_start_s = 0;        // audio track start relative to the first frame (negative: before)
  int crf = 14;                    // libx264 constant rate factor (lower = better)
  std::string x264_preset = "medium";
  int display_rotation_deg = 0;    // 0/90/180/270: phone-style "rotate" metadata (clockwise)
  std::string audio_wav;           // mono WAV muxed as AAC; empty = no audio
  void Check() const;
};

// Streams 8-bit sRGB frames into `ffmpeg ... -c:v libx264 -pix_fmt yuv420p`
// writing an MP4 (BT.709 matrix, sRGB transfer tag, AAC audio at
// audio_rate_hz).
class VideoEncoder {
 public:
  VideoEncoder(const std::string& output_mp4, const VideoEncodeParams& params);
  ~VideoEncoder();  // abandons (kills the pipe) unless Finish() was called
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  // rgb: width*height*3 bytes, row-major, top row first.
  void AddFrame(const std::vector<uint8_t>& rgb);
  // Closes the pipe and waits; throws relit::Error with ffmpeg's message on failure.
  void Finish();
  int frames_written() const { return frames_; }

 private:
  std::string output_, encoded_, log_path_;
  VideoEncodeParams params_;
  FILE* pipe_ = nullptr;
  int frames_ = 0;
};

// Decodes every frame of a video as 8-bit grey (luma) or RGB, ignoring any
// rotation metadata, one output frame per stored frame. Returns frames of width*height*(1 or 3) bytes.
struct DecodedVideo {
  int width_px = 0, height_px = 0, channels = 0;
  std::vector<std::vector<uint8_t>> frames;
};
DecodedVideo DecodeVideo(const std::string& path, bool grey);

// Decodes the first audio stream as mono float samples at `sample_rate_hz`.
std::vector<float> DecodeAudio(const std::string& path, int sample_rate_hz);

// Stream properties read with ffprobe: width, height, frame count, frame rate,
// clockwise display rotation as players apply it (0 if none), audio sample rate (0 if
// no audio).
struct MediaInfo {
  int width_px = 0, height_px = 0, frame_count = 0;
  double fps = 0;
  int rotation_deg = 0;
  int audio_sample_rate_hz = 0;
  // Stream start times (ffprobe start_time): the first frame's and the first
  // decoded audio sample's presentation time in the file.
  double video_start_s = 0, audio_start_s = 0;
  std::string video_codec, pix_fmt, color_transfer;
};
MediaInfo ProbeMedia(const std::string& path);


}  // namespace relit::synth
