#include "tools/synth/ffmpeg_io.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tools/synth/audio.h"

namespace relit::synth {
namespace {

namespace fs = std::filesystem;

TEST(FfmpegIo, EncodesDecodesAndTagsRotation) {
  const fs::path dir = fs::temp_directory_path() / ("relit_synth_ffmpeg_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const int width = 64, height = 48, frames = 6;
  std::vector<float> audio(frames * 1600);
  for (size_t n = 0; n < audio.size(); ++n) audio[n] = 0.3f * std::sin(0.05f * n);
  WriteWav((dir / "a.wav").string(), audio, 48000);
  VideoEncodeParams params;
  params.width_px = width;
  params.height_px = height;
  params.display_rotation_deg = 90;
  params.audio_wav = (dir / "a.wav").string();
  VideoEncoder encoder((dir / "v.mp4").string(), params);
  for (int f = 0; f < frames; ++f) {
    std::vector<uint8_t> rgb(width * height * 3);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const uint8_t v = (x / 8 + y / 8 + f) % 2 ? 200 : 40;
        for (int c = 0; c < 3; ++c) rgb[(y * width + x) * 3 + c] = v;
      }
    }
    encoder.AddFrame(rgb);
  }
  encoder.Finish();
  const MediaInfo info = ProbeMedia((dir / "v.mp4").string());
  EXPECT_EQ(info.frame_count, frames);
  EXPECT_EQ(info.width_px, width);
  EXPECT_EQ(info.height_px, height);
  EXPECT_EQ(info.rotation_deg, 90);
  EXPECT_EQ(info.audio_sample_rate_hz, 48000);
  EXPECT_EQ(info.color_transfer, "iec61966-2-1");
  const DecodedVideo video = DecodeVideo((dir / "v.mp4").string(), /*grey=*/true);
  ASSERT_EQ(video.frames.size(), static_cast<size_t>(frames));
  ASSERT_EQ(video.width_px, width);  // rotation metadata does not rotate the pixels
  // Grey levels survive encoding (full range out, limited range inside).
  const uint8_t dark = video.frames[0][4 * width + 4], bright = video.frames[0][4 * width + 12];
  EXPECT_NEAR(dark, 40, 4);
  EXPECT_NEAR(bright, 200, 4);
  const std::vector<float> decoded = DecodeAudio((dir / "v.mp4").string(), 48000);
  EXPECT_NEAR(static_cast<double>(decoded.size()), static_cast<double>(audio.size()), 1100);
  fs::remove_all(dir);
}

TEST(FfmpegIo, ErrorsAreReadable) {
  EXPECT_THROW(ProbeMedia("/nonexistent/video.mp4"), std::runtime_error);
  VideoEncodeParams odd;
  odd.width_px = 63;
  odd.height_px = 48;
  EXPECT_THROW(odd.Check(), std::runtime_error);
  EXPECT_EQ(ShellQuote("it's"), "'it'\\''s'");
}

}  // namespace
}  // namespace relit::synth
