// Pixel and timestamp fidelity of relit-capture on videos encoded from known
// images: linearisation error bound, rotation metadata, variable frame rate
// and HDR (HLG) detection.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "capture/capture.h"
#include "capture/test_media.h"
#include "capture/transfer.h"
#include "core/color.h"
#include "core/error.h"
#include "core/image.h"

namespace relit::capture {
namespace {

namespace fs = std::filesystem;
using testing::ReadCaptureJson;
using testing::Shell;
using testing::TempDir;
using testing::TestOptions;

constexpr int kWidth = 128, kHeight = 96, kPatch = 16, kMargin = 4, kFrames = 4;
// The synthetic generator's encoder settings (tools/synth/ffmpeg_io.cc).
const char* kEncodeSdr =
    " -vf scale=out_color_matrix=bt709:out_range=tv -c:v libx264 -preset medium -crf 14 "
    "-pix_fmt yuv420p -color_primaries bt709 -color_trc iec61966-2-1 -colorspace bt709 "
    "-color_range tv";

// Frame f: flat 16x16 patches of sRGB codes spread over [0, 255].
cv::Mat PatchFrame(int f) {
  cv::Mat rgb(kHeight, kWidth, CV_8UC3);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const int p = (y / kPatch) * (kWidth / kPatch) + x / kPatch;
      rgb.at<cv::Vec3b>(y, x) = cv::Vec3b((p * 37 + f * 11) % 256, (p * 71 + 90 + f * 5) % 256,
                                          (p * 13 + 200 + f * 3) % 256);
    }
  }
  return rgb;
}

void WriteFrames(const TempDir& dir) {
  for (int f = 0; f < kFrames; ++f) {
    cv::Mat bgr;
    cv::cvtColor(PatchFrame(f), bgr, cv::COLOR_RGB2BGR);
    char name[32];
    std::snprintf(name, sizeof(name), "f%03d.png", f);
    ASSERT_TRUE(cv::imwrite(dir / name, bgr));
  }
}

// Phone L: the same frames remuxed into a file of its own (relit refuses one
// file, or two identical copies, as both phones).
std::string LightCopy(const std::string& view) {
  const std::filesystem::path p(view);
  const std::string light = (p.parent_path() / (p.stem().string() + "_light" + p.extension().string())).string();
  if (!std::filesystem::exists(light)) {
    Shell("ffmpeg -nostdin -v error -y -i " + view + " -map 0 -c copy -metadata title=phone-L " + light);
  }
  return light;
}

CaptureOptions LenientOptions(const std::string& view, const std::string& out) {
  CaptureOptions o = TestOptions(view, LightCopy(view), out);
  o.sync.offset_s = 0.0;
  o.view_select.target_frames = 1000;
  o.view_select.min_blur_ratio = 0;
  o.view_select.max_dark_fraction = 1;
  o.view_select.max_clipped_fraction = 1;
  return o;
}

// Max |error| over patch interiors (4 px from patch edges: chroma is
// subsampled 2x2 and coded in 4x4 blocks, which ring at colour edges)
// between a linear frame and the linear truth.
struct Errors {
  double linear_max = 0, encoded_max = 0, encoded_mean = 0;
};
Errors Compare(const Image& linear, const cv::Mat& truth_rgb8,
               float (*decode)(float) = SrgbToLinear) {
  Errors e;
  int n = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (x % kPatch < kMargin || x % kPatch >= kPatch - kMargin || y % kPatch < kMargin ||
          y % kPatch >= kPatch - kMargin) {
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        const float code = truth_rgb8.at<cv::Vec3b>(y, x)[c] / 255.0f;
        const float got = linear.at(x, y, c);
        e.linear_max = std::max<double>(e.linear_max, std::abs(got - decode(code)));
        const double encoded = std::abs(LinearToSrgb(std::clamp(got, 0.0f, 1.0f)) - LinearToSrgb(decode(code)));
        e.encoded_max = std::max(e.encoded_max, encoded);
        e.encoded_mean += encoded;
        ++n;
      }
    }
  }
  e.encoded_mean /= n;
  return e;
}

TEST(CaptureFormat, LinearisedFramesMatchTruthWithinH264Quantisation) {
  TempDir dir("linear");
  WriteFrames(dir);
  Shell("ffmpeg -nostdin -v error -y -framerate 30 -i " + (dir / "f%03d.png") + kEncodeSdr + " " +
        (dir / "v.mp4"));
  RunCaptureImpl(LenientOptions(dir / "v.mp4", dir / "out"));
  const nlohmann::json capture = ReadCaptureJson(dir / "out");
  ASSERT_EQ(capture["view_frames"].size(), static_cast<size_t>(kFrames));
  Errors worst;
  for (const auto& frame : capture["view_frames"]) {
    const Image linear = ReadImage(dir / "out/" + frame["linear"].get<std::string>());
    ASSERT_EQ(linear.width(), kWidth);
    const Errors e = Compare(linear, PatchFrame(frame["source_frame"]));
    worst.linear_max = std::max(worst.linear_max, e.linear_max);
    worst.encoded_max = std::max(worst.encoded_max, e.encoded_max);
    worst.encoded_mean = std::max(worst.encoded_mean, e.encoded_mean);
    // The 8-bit copy is the sRGB encoding of the linear frame.
    const cv::Mat png = cv::imread(dir / "out/" + frame["image"].get<std::string>());
    ASSERT_EQ(png.cols, kWidth);
  }
  std::cout << "linearisation error (x264 crf 14, yuv420p, BT.709 tv): linear max "
            << worst.linear_max << ", sRGB-encoded max " << worst.encoded_max * 255
            << "/255, mean " << worst.encoded_mean * 255 << "/255\n";
  // Bound (measured 4.2/255 max, 0.8/255 mean): 8-bit limited-range Y'CbCr
  // quantisation (about +-1 code per channel after the RGB conversion) plus
  // crf-14 coding noise on 4:2:0 chroma: at most 5 codes of 255 in the
  // encoded domain, i.e. at most 5/255 x 2.27 (the largest slope of the
  // sRGB decoding) = 0.045 in linear; below 1 code on average.
  EXPECT_LT(worst.encoded_max, 5.0 / 255);
  EXPECT_LT(worst.encoded_mean, 1.0 / 255);
  EXPECT_LT(worst.linear_max, 5.0 / 255 * 2.27);
}

TEST(CaptureFormat, LosslessVideoLinearisesToTheQuantisationBound) {
  // x264 lossless 4:4:4: what remains is the 8-bit Y'CbCr rounding alone, so
  // a wrong matrix, range or transfer in the stage would show up here.
  TempDir dir("lossless");
  WriteFrames(dir);
  Shell("ffmpeg -nostdin -v error -y -framerate 30 -i " + (dir / "f%03d.png") +
        " -vf scale=out_color_matrix=bt709:out_range=tv -c:v libx264 -qp 0 -pix_fmt yuv444p "
        "-color_primaries bt709 -color_trc iec61966-2-1 -colorspace bt709 -color_range tv " +
        (dir / "v.mp4"));
  RunCaptureImpl(LenientOptions(dir / "v.mp4", dir / "out"));
  const nlohmann::json capture = ReadCaptureJson(dir / "out");
  for (const auto& frame : capture["view_frames"]) {
    const Image linear = ReadImage(dir / "out/" + frame["linear"].get<std::string>());
    const Errors e = Compare(linear, PatchFrame(frame["source_frame"]));
    std::cout << "lossless: sRGB-encoded max " << e.encoded_max * 255 << "/255, mean "
              << e.encoded_mean * 255 << "/255\n";
    // Rounding to 8-bit Y'CbCr on encode and of the decode (~1.5 codes
    // each at worst for R and B): measured 2.2/255 max, 0.7/255 mean.
    EXPECT_LT(e.encoded_max, 3.0 / 255);
    EXPECT_LT(e.encoded_mean, 1.0 / 255);
  }
}

TEST(CaptureFormat, Gamma22OptionAndRotationMetadata) {
  TempDir dir("rotation");
  WriteFrames(dir);
  // ffmpeg 5.1 writes the display matrix for a "rotate" tag only when remuxing.
  Shell("ffmpeg -nostdin -v error -y -framerate 30 -i " + (dir / "f%03d.png") + kEncodeSdr + " " +
        (dir / "plain.mp4"));
  Shell("ffmpeg -nostdin -v error -y -i " + (dir / "plain.mp4") +
        " -c copy -metadata:s:v:0 rotate=90 " + (dir / "r.mp4"));
  // How players show it: ffmpeg's own autorotation.
  Shell("ffmpeg -nostdin -v error -y -i " + (dir / "r.mp4") +
        " -vf scale=in_color_matrix=bt709:in_range=tv:out_range=pc -frames:v 1 " +
        (dir / "shown.png"));
  CaptureOptions o = LenientOptions(dir / "r.mp4", dir / "out");
  o.transfer = "gamma2.2";
  RunCaptureImpl(o);
  const nlohmann::json capture = ReadCaptureJson(dir / "out");
  EXPECT_NE(capture["inputs"]["view"]["rotation_deg"], 0);
  EXPECT_EQ(capture["inputs"]["view"]["width_px"], kHeight);
  EXPECT_EQ(capture["inputs"]["view"]["height_px"], kWidth);
  const auto& frame = capture["view_frames"][0];
  ASSERT_EQ(frame["source_frame"], 0);
  const cv::Mat shown = cv::imread(dir / "shown.png");  // BGR
  const Image linear = ReadImage(dir / "out/" + frame["linear"].get<std::string>());
  ASSERT_EQ(linear.width(), shown.cols);
  ASSERT_EQ(linear.height(), shown.rows);
  // Same orientation as the player, and gamma 2.2 undone. The player frame
  // is upsampled differently at chroma edges, so compare with the same frame
  // turned upside down: the right orientation must be far closer.
  cv::Mat flipped;
  cv::flip(shown, flipped, -1);
  double error = 0, wrong = 0;
  for (int y = 0; y < shown.rows; ++y) {
    for (int x = 0; x < shown.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float v = linear.at(x, y, c);
        error += std::abs(v - Gamma22ToLinear(shown.at<cv::Vec3b>(y, x)[2 - c] / 255.0f));
        wrong += std::abs(v - Gamma22ToLinear(flipped.at<cv::Vec3b>(y, x)[2 - c] / 255.0f));
      }
    }
  }
  error /= shown.total() * 3;
  wrong /= shown.total() * 3;
  std::cout << "rotation test: mean |linear - gamma2.2(player frame)| = " << error
            << ", upside down " << wrong << "\n";
  EXPECT_LT(error, 0.03);
  EXPECT_LT(error, 0.2 * wrong);
}

TEST(CaptureFormat, VariableFrameRateKeepsPresentationTimes) {
  TempDir dir("vfr");
  // 10 frames at 30 fps, then 20 at 10 fps; frame n has luma 60 + 5 n.
  Shell("ffmpeg -nostdin -v error -y -f lavfi -i color=c=gray:size=160x120:rate=30:d=1 -vf "
        "\"geq=lum='60+5*N':cb=128:cr=128,settb=1/90000,setpts='if(lt(N,10),N*3000,"
        "30000+(N-10)*9000)'\" -fps_mode passthrough -enc_time_base 1:90000 "
        "-video_track_timescale 90000 -c:v libx264 -crf 10 -pix_fmt yuv420p " + (dir / "vfr.mp4"));
  RunCaptureImpl(LenientOptions(dir / "vfr.mp4", dir / "out"));
  const nlohmann::json capture = ReadCaptureJson(dir / "out");
  const auto& frames = capture["view_frames"];
  ASSERT_EQ(frames.size(), 30u);
  for (const auto& frame : frames) {
    const int n = frame["source_frame"];
    const double expected = n < 10 ? n / 30.0 : 1.0 / 3.0 + (n - 10) / 10.0;
    EXPECT_NEAR(frame["time_s"].get<double>(), expected, 1e-6) << "frame " << n;
    // The pixels belong to that timestamp: full-range grey of luma 60 + 5 n.
    const cv::Mat png = cv::imread(dir / "out/" + frame["image"].get<std::string>(), cv::IMREAD_GRAYSCALE);
    const double expected_grey = (60 + 5 * n - 16) * 255.0 / 219.0;
    EXPECT_NEAR(cv::mean(png)[0], expected_grey, 2.0) << "frame " << n;
  }
}

TEST(CaptureFormat, HlgVideoIsRefusedOrLinearised) {
  TempDir dir("hlg");
  const double codes[4] = {0.2, 0.45, 0.6, 0.8};
  for (int f = 0; f < 3; ++f) {
    cv::Mat grey(kHeight, kWidth, CV_16UC3);
    for (int x = 0; x < kWidth; ++x) {
      const double code = codes[x / 32] + 0.01 * f;
      grey.col(x).setTo(cv::Scalar::all(std::round(code * 65535)));
    }
    char name[32];
    std::snprintf(name, sizeof(name), "h%03d.png", f);
    ASSERT_TRUE(cv::imwrite(dir / name, grey));
  }
  Shell("ffmpeg -nostdin -v error -y -framerate 30 -i " + (dir / "h%03d.png") +
        " -vf scale=out_color_matrix=bt2020:out_range=tv,format=yuv420p10le -c:v libx265 "
        "-x265-params log-level=error:crf=4 -pix_fmt yuv420p10le -color_primaries bt2020 "
        "-color_trc arib-std-b67 -colorspace bt2020nc -color_range tv " + (dir / "hlg.mp4"));
  CaptureOptions o = LenientOptions(dir / "hlg.mp4", dir / "out");
  try {
    RunCaptureImpl(o);
    ADD_FAILURE() << "HDR video accepted with transfer auto";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("HDR video (HLG"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--transfer hlg"), std::string::npos) << e.what();
  }
  o.transfer = "hlg";
  RunCaptureImpl(o);
  const nlohmann::json capture = ReadCaptureJson(dir / "out");
  EXPECT_EQ(capture["inputs"]["view"]["bit_depth"], 10);
  EXPECT_EQ(capture["inputs"]["view"]["codec"], "hevc");
  for (const auto& frame : capture["view_frames"]) {
    const int f = frame["source_frame"];
    const Image linear = ReadImage(dir / "out/" + frame["linear"].get<std::string>());
    for (int i = 0; i < 4; ++i) {
      const double truth = HlgToSceneLinear(codes[i] + 0.01 * f) / HlgToSceneLinear(0.75);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(linear.at(32 * i + 16, kHeight / 2, c), truth, 0.02 * truth + 0.002)
            << "frame " << f << " patch " << i;
      }
    }
  }
}

}  // namespace
}  // namespace relit::capture
