#include "tools/synth/audio.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

namespace relit::synth {
namespace {

TEST(Audio, CrossCorrelationRecoversTheRecordingOffset) {
  const RoomSoundParams params;
  for (double offset_s : {-2.7, -0.31, 0.2, 1.234567}) {
    const double duration = 4.0;
    const double begin = std::min(0.0, offset_s) - 0.01, end = std::max(duration, offset_s + duration) + 0.01;
    const auto claps = PickClapTimes(std::max(0.0, offset_s) + 0.05, std::min(duration, offset_s + duration) - 0.05,
                                     3, 0.05, 9);
    const RoomSound room(params, begin, end, claps, 42);
    const int64_t n = static_cast<int64_t>(duration * params.sample_rate_hz);
    const auto view = room.Record(0.0, n, 1.0, 1);
    const auto light = room.Record(offset_s, n, 0.8, 2);
    EXPECT_NEAR(CrossCorrelationLagS(view, light, params.sample_rate_hz, 3.5), offset_s, 1e-4);
    // Unrelated recordings (different rooms) do not produce this peak by chance.
    const RoomSound other(params, begin, end, PickClapTimes(claps.front(), claps.back(), 3, 0.05, 10), 43);
    const auto unrelated = other.Record(offset_s, n, 0.8, 3);
    EXPECT_GT(std::abs(CrossCorrelationLagS(view, unrelated, params.sample_rate_hz, 3.5) - offset_s), 1e-3);
  }
}

TEST(Audio, ClapsAreLoudAndInsideTheInterval) {
  const auto claps = PickClapTimes(1.0, 2.0, 4, 0.1, 5);
  ASSERT_EQ(claps.size(), 4u);
  for (size_t i = 0; i < claps.size(); ++i) {
    EXPECT_GE(claps[i], 1.0);
    EXPECT_LE(claps[i], 2.0);
    if (i > 0) {
      EXPECT_GE(claps[i] - claps[i - 1], 0.1 - 1e-12);
    }
  }
  const RoomSoundParams params;
  const RoomSound room(params, 0.0, 3.0, claps, 1);
  const auto samples = room.Record(0.0, 3 * params.sample_rate_hz, 1.0, 1);
  for (double clap : claps) {
    float peak = 0;
    const int64_t at = static_cast<int64_t>(clap * params.sample_rate_hz);
    for (int64_t k = at; k < at + 480; ++k) peak = std::max(peak, std::abs(samples[k]));
    EXPECT_GT(peak, 10 * params.room_noise_rms);
  }
  EXPECT_THROW(PickClapTimes(0, 0.1, 5, 0.1, 1), std::runtime_error);
}

TEST(Audio, WritesAValidWav) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("relit_synth_wav_" + std::to_string(::getpid()) + ".wav")).string();
  WriteWav(path, {0.0f, 0.5f, -1.5f}, 48000);
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  ASSERT_EQ(bytes.size(), 44u + 6u);
  EXPECT_EQ(bytes.substr(0, 4), "RIFF");
  EXPECT_EQ(bytes.substr(8, 8), "WAVEfmt ");
  const auto sample = [&](int i) {
    return static_cast<int16_t>(static_cast<uint8_t>(bytes[44 + 2 * i]) |
                                (static_cast<uint8_t>(bytes[45 + 2 * i]) << 8));
  };
  EXPECT_EQ(sample(0), 0);
  EXPECT_EQ(sample(1), 16384);
  EXPECT_EQ(sample(2), -32767);  // clipped
}

}  // namespace
}  // namespace relit::synth
