// Video and audio decoding through the ffmpeg/ffprobe command-line tools.
// Nothing is linked against libav*: frames travel as raw pixels through a
// pipe, and per-frame presentation timestamps come from ffmpeg's showinfo
// filter in the same decoding pipeline, so timestamps and pixels can never
// disagree (frames are passed through, never duplicated or dropped, which
// keeps variable-frame-rate video correct).
//
// Times are container presentation timestamps in seconds (ffmpeg -copyts),
// the device's own clock for that recording.
#pragma once

#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include "core/shell.h"

namespace relit::capture {

struct VideoInfo {
  std::string path;
  std::string role;                   // e.g. "phone V video (--view)", for messages
  std::string container, codec, pix_fmt;
  std::string color_transfer, color_space, color_range, color_primaries;  // ffprobe names
  int coded_width_px = 0, coded_height_px = 0;  // as stored in the stream
  int width_px = 0, height_px = 0;    // as displayed, after the rotation
  int rotation_deg = 0;               // clockwise display rotation (0, 90, 180, 270)
  int bit_depth = 8;
  double duration_s = 0;
  int64_t header_frame_count = 0;     // from the container; 0 when unknown
  bool has_audio = false;
  int audio_sample_rate_hz = 0;
};

// Reads stream properties with ffprobe. Throws relit::Error naming the file
// and the role when it is missing, unreadable, truncated or not a video.
VideoInfo ProbeVideo(const std::string& path, const std::string& role);

// The first decoding error of a pass, if any.
struct DecodeIssue {
  bool found = false;
  int frames_before = 0;     // frames decoded before the error
  double time_s = 0;         // presentation time of the last good frame (or 0)
  std::string message;       // ffmpeg's message
};

struct AnalysisPass {
  std::vector<double> times_s;  // per decoded frame, presentation order
  DecodeIssue issue;
};

// Pass 1: decodes every frame as 8-bit grey (luma) at most `max_width_px`
// wide, without rotation, calling on_frame(index, grey CV_8UC1) in order.
AnalysisPass AnalyseVideo(const VideoInfo& info, int max_width_px,
                          const std::function<void(int, const cv::Mat&)>& on_frame);

// Pass 2: frames as 16-bit RGB (CV_16UC3, R,G,B order), full range, rotated
// for display, decoded with the stream's YUV matrix and range.
class FrameReader {
 public:
  explicit FrameReader(const VideoInfo& info);
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  // Next frame in presentation order; false at the end of the stream.
  bool Next(cv::Mat* rgb16);
  // Index of the frame returned by the last Next().
  int index() const { return index_; }
  // Stops ffmpeg (frames not read yet are discarded).
  void Close();

 private:
  VideoInfo info_;
  std::string log_path_;
  FILE* pipe_ = nullptr;
  int index_ = -1;
};

struct AudioTrack {
  std::vector<float> samples;  // mono
  int sample_rate_hz = 0;
  // Presentation time of samples[0]: the timestamp of the first frame the
  // decoder outputs, after the container's edit list and the encoder delay
  // (AAC priming) have been applied. Never read from a truncated log.
  double start_s = 0;
  double stream_start_s = 0;       // ffprobe's stream start_time (for the record)
  double first_packet_pts_s = 0;   // first packet's pts (negative with priming)
  double duration_s() const {
    return sample_rate_hz > 0 ? static_cast<double>(samples.size()) / sample_rate_hz : 0.0;
  }
};

// Where the first audio stream starts, from its timestamps: ffprobe's
// stream start_time and first packet pts, and the presentation time of the
// first decoded frame (ffmpeg -copyts, ashowinfo on that frame only).
struct AudioStart {
  double decoded_s = 0, stream_s = 0, first_packet_s = 0;
};
AudioStart ProbeAudioStart(const VideoInfo& info);

// Decodes the first audio stream as mono float at `sample_rate_hz`; the
// samples come through stdout in full, the start from ProbeAudioStart.
AudioTrack DecodeAudio(const VideoInfo& info, int sample_rate_hz);

// Size and a content hash (FNV-1a 64 over every byte, hex) of a file, so a
// later run can tell whether an input changed.
struct FileFingerprint {
  uint64_t size_bytes = 0;
  std::string fnv1a64;
};
FileFingerprint Fingerprint(const std::string& path);


}  // namespace relit::capture
