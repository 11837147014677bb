// Unit tests of the capture stage's parts: GCC-PHAT sync, frame scores and
// selection, transfer functions and options.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "capture/audio_sync.h"
#include "capture/capture_options.h"
#include "capture/frame_select.h"
#include "capture/transfer.h"
#include "core/error.h"

namespace relit::capture {
namespace {

// Broadband room sound on a 10x finer grid than the recordings (160 kHz,
// smoothed over 10 samples against aliasing), so recordings can start at
// any multiple of 6.25 us; each recording adds its own microphone noise.
constexpr int kRate = 16000, kFine = 10;
struct Room {
  std::vector<float> fine;
  explicit Room(int seed, double seconds = 8.0) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0, 0.1f);
    std::vector<float> white(static_cast<size_t>(seconds * kRate * kFine) + kFine);
    for (float& v : white) v = noise(rng);
    fine.resize(white.size() - kFine);
    for (size_t i = 0; i < fine.size(); ++i) {
      for (int k = 0; k < kFine; ++k) fine[i] += white[i + k] / kFine;
    }
  }
};

// A recording starting at room time start_s (a multiple of 1 / 160 kHz).
std::vector<float> Record(const Room& room, double start_s, double seconds, int noise_seed) {
  std::mt19937 rng(noise_seed);
  std::normal_distribution<float> noise(0, 0.01f);
  const int64_t first = std::llround(start_s * kRate * kFine);
  std::vector<float> samples(static_cast<size_t>(seconds * kRate));
  for (size_t n = 0; n < samples.size(); ++n) samples[n] = room.fine.at(first + n * kFine) + noise(rng);
  return samples;
}

TEST(GccPhat, RecoversFractionalOffsetsOfBothSigns) {
  const Room room(5);
  // Offsets in units of 1/160 kHz: fractions of a 16 kHz sample.
  for (int fine_steps : {19753, -104691, 0, 240003}) {
    const double offset = fine_steps / double(kRate * kFine);
    // Phone L started `offset` after phone V: its sample m is at V time m/rate + offset.
    const auto a = Record(room, 2.0, 3.0, 1);
    const auto b = Record(room, 2.0 + offset, 3.0, 2);
    const LagEstimate e = GccPhatLag(a, b, kRate, 2.0, 0.005);
    EXPECT_NEAR(e.lag_s, offset, 15e-6) << offset;  // a quarter of a sample
    EXPECT_GT(e.confidence, 3.0);
  }
}

TEST(GccPhat, UnrelatedSoundsHaveLowConfidence) {
  const auto a = Record(Room(1), 0.0, 3.0, 1);
  const auto b = Record(Room(2), 0.0, 3.0, 2);
  const LagEstimate e = GccPhatLag(a, b, kRate, 2.0, 0.005);
  EXPECT_LT(e.confidence, 1.6);
  EXPECT_GE(e.confidence, 1.0);
}

TEST(GccPhat, OffsetOutsideTheWindowIsNotFound) {
  const Room room(5);
  const auto a = Record(room, 2.0, 3.0, 1);
  const auto b = Record(room, 3.2, 3.0, 2);
  const LagEstimate e = GccPhatLag(a, b, kRate, 0.5, 0.005);
  EXPECT_LE(std::abs(e.lag_s), 0.5);
  EXPECT_LT(e.confidence, 2.0);
}

TEST(GccPhat, RejectsSilence) {
  EXPECT_THROW(GccPhatLag(std::vector<float>(1000, 0.0f), std::vector<float>(1000, 0.1f), 16000, 0.01, 0.001),
               Error);
}

cv::Mat Texture(int seed) {
  cv::Mat grey(120, 160, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(grey, cv::RNG::UNIFORM, 40, 200);
  cv::GaussianBlur(grey, grey, cv::Size(), 1.0);
  return grey;
}

TEST(FrameSelect, RejectsBlurredDarkClippedAndDuplicateFrames) {
  SelectOptions o;
  o.target_frames = 1000;
  std::vector<Candidate> frames;
  cv::Mat previous;
  for (int i = 0; i < 20; ++i) {
    cv::Mat grey = i == 6 ? previous.clone() : Texture(i);
    if (i == 9) cv::GaussianBlur(grey, grey, cv::Size(), 2.5);
    if (i == 12) grey.setTo(2);
    if (i == 15) grey.rowRange(0, 40).setTo(255);
    Candidate c;
    c.source_frame = i;
    c.source_time_s = c.time_s = i / 30.0;
    c.score = ScoreFrame(grey, previous, o);
    frames.push_back(c);
    previous = grey;
  }
  RejectBadFrames(&frames, o);
  for (int i = 0; i < 20; ++i) {
    const std::string expected = i == 6 ? kDuplicate : i == 9 ? kBlurred : i == 12 ? kDark
                               : i == 15 ? kClipped : "";
    EXPECT_EQ(frames[i].rejection, expected) << "frame " << i << " blur ratio " << frames[i].blur_ratio;
  }
  EXPECT_LT(frames[9].blur_ratio, 0.3);
}

TEST(FrameSelect, SubsampleKeepsTheSharpestFramePerTimeBin) {
  SelectOptions o;
  o.target_frames = 5;
  std::vector<Candidate> frames(50);
  for (int i = 0; i < 50; ++i) {
    frames[i].source_frame = i;
    frames[i].time_s = i * 0.1;
    frames[i].score.sharpness = (i % 10 == 3) ? 2.0 : 1.0;
  }
  Subsample(&frames, o);
  std::vector<int> kept;
  for (const Candidate& c : frames) {
    if (c.rejection.empty()) kept.push_back(c.source_frame);
    else EXPECT_EQ(c.rejection, kNotSelected);
  }
  EXPECT_EQ(kept, (std::vector<int>{3, 13, 23, 33, 43}));
}

TEST(FrameSelect, LightFramesAroundATime) {
  const std::vector<double> t = {0.0, 0.1, 0.2, 0.3, 0.4};
  EXPECT_EQ(LightFramesAround(0.15, t, 1), (std::vector<int>{1, 2}));
  EXPECT_EQ(LightFramesAround(0.15, t, 2), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(LightFramesAround(0.2, t, 1), (std::vector<int>{2}));
  EXPECT_EQ(LightFramesAround(0.0, t, 2), (std::vector<int>{0, 1}));
  EXPECT_TRUE(LightFramesAround(-0.01, t, 2).empty());
  EXPECT_TRUE(LightFramesAround(0.41, t, 2).empty());
}

TEST(FrameSelect, ThinByTimeKeepsFramesAtLeastTheSpacingApart) {
  std::vector<double> t;
  const double interval = 1001.0 / 30000.0;  // 29.97 fps
  for (int i = 0; i < 60; ++i) t.push_back(0.3 + i * interval);
  EXPECT_EQ(ThinByTime(t, 0).size(), t.size());
  const std::vector<int> kept = ThinByTime(t, 0.06);
  ASSERT_EQ(kept.size(), 31u);  // 0, 2, ..., 58 and the last frame, 59
  EXPECT_EQ(kept.front(), 0);
  EXPECT_EQ(kept.back(), 59);
  for (size_t k = 1; k + 1 < kept.size(); ++k) {
    EXPECT_GE(t[kept[k]] - t[kept[k - 1]], 0.06);
    EXPECT_LT(t[kept[k]] - t[kept[k - 1]], 0.06 + interval);
  }
  EXPECT_EQ(ThinByTime(t, 10.0), (std::vector<int>{0, 59}));
  EXPECT_TRUE(ThinByTime({}, 0.06).empty());
}

TEST(Transfer, HdrCurvesHitKnownPoints) {
  EXPECT_NEAR(HlgToSceneLinear(0.5), 1.0 / 12.0, 1e-9);
  EXPECT_NEAR(HlgToSceneLinear(1.0), 1.0, 1e-6);
  EXPECT_NEAR(PqToNits(1.0), 10000.0, 1e-6);
  EXPECT_NEAR(PqToNits(0.58), 203.0, 2.0);  // BT.2408 reference white is ~58% PQ
  const Linearizer srgb(Transfer::kSrgb, false);
  cv::Mat rgb16(1, 1, CV_16UC3, cv::Scalar(65535, 32768, 0));
  const cv::Vec3f linear = srgb.ToLinear(rgb16).at<cv::Vec3f>(0, 0);
  EXPECT_NEAR(linear[0], 1.0, 1e-6);
  EXPECT_NEAR(linear[1], 0.2140, 1e-3);
  EXPECT_EQ(linear[2], 0.0f);
}

TEST(Transfer, AutoRefusesHdrWithAdvice) {
  VideoInfo info;
  info.path = "clip.mov";
  info.role = "phone V video (--view)";
  info.color_transfer = "smpte2084";
  try {
    ResolveTransfer(info, "auto");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--transfer pq"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ResolveTransfer(info, "pq"), Transfer::kPq);
  info.color_transfer = "bt709";
  EXPECT_EQ(ResolveTransfer(info, "auto"), Transfer::kSrgb);
}

TEST(CaptureOptionsTest, YamlOverridesAndUnknownKeys) {
  OptionsReader reader = OptionsReader::FromString(
      "view: v.mp4\nlight: l.mp4\nout: ws/capture\nsync:\n  offset_s: 0.5\nview_select:\n"
      "  target_frames: 40\n");
  CaptureOptions o;
  ReadOptions(reader, &o);
  CheckOptions(o);
  ASSERT_TRUE(o.sync.offset_s.has_value());
  EXPECT_EQ(*o.sync.offset_s, 0.5);
  EXPECT_EQ(o.view_select.target_frames, 40);
  OptionsReader typo = OptionsReader::FromString("view_select:\n  min_blur_ration: 0.5\n");
  CaptureOptions p;
  try {
    ReadOptions(typo, &p);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("min_blur_ratio"), std::string::npos) << e.what();
  }
  OptionsReader absurd = OptionsReader::FromString("sync:\n  sample_rate_hz: 5\n");
  EXPECT_THROW(ReadOptions(absurd, &p), Error);
}

}  // namespace
}  // namespace relit::capture
