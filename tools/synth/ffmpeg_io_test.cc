#include "tools/synth/ffmpeg_io.h"

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

#include "tools/synth/audio.h"
#include "tools/synth/synth.h"

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
        uint8_t v = (x / 8 + y / 8 + f) % 2 ? 200 : 40;
        if (x >= 16 && x < 24 && y < 8) v = 255;  // shows which way players turn the frame
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
  // Players (ffmpeg's autorotation) turn it 90 degrees clockwise: stored
  // (x, y) is shown at (height - 1 - y, x). ffmpeg 5.1 reads its own
  // "rotate" tag the other way round; the encoder compensates.
  const CommandResult shown = RunCommand("ffmpeg -nostdin -v error -i " + ShellQuote((dir / "v.mp4").string()) +
                                         " -frames:v 1 -f rawvideo -pix_fmt gray -");
  ASSERT_TRUE(shown.ok());
  ASSERT_EQ(shown.out.size(), static_cast<size_t>(width * height));
  const auto shown_at = [&](int x, int y) { return static_cast<uint8_t>(shown.out[y * height + x]); };
  EXPECT_GT(shown_at(height - 1 - 4, 20), 240);  // stored (20, 4)
  EXPECT_LT(shown_at(4, width - 1 - 20), 240);   // where a counter-clockwise turn would put it
  // The board clips' PNGs are turned the same way as players turn the video.
  Image stored(width, height, 1);
  stored.at(20, 4, 0) = 1.0f;
  for (int rotation : {90, 180, 270}) {
    const Image turned = RotatedForDisplay(stored, rotation);
    EXPECT_EQ(turned.width(), rotation == 180 ? width : height) << rotation;
    const int x = rotation == 90 ? height - 1 - 4 : rotation == 180 ? width - 1 - 20 : 4;
    const int y = rotation == 90 ? 20 : rotation == 180 ? height - 1 - 4 : width - 1 - 20;
    EXPECT_EQ(turned.at(x, y, 0), 1.0f) << rotation;
  }
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
