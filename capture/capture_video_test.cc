// End-to-end tests of relit-capture on small videos made with ffmpeg: audio
// sync, variable frame rate, linearisation, rotation and every bad input.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "capture/capture.h"
#include "capture/test_media.h"
#include "capture/transfer.h"
#include "capture/video_io.h"
#include "core/color.h"
#include "core/error.h"
#include "core/image.h"

namespace relit::capture {
namespace {

namespace fs = std::filesystem;
using testing::MakeRoomSound;
using testing::MakeVideo;
using testing::ReadCaptureJson;
using testing::Shell;
using testing::TempDir;
using testing::TestOptions;

// Runs the stage expecting a relit::Error containing every part, and checks
// that nothing was written.
void ExpectFailure(const CaptureOptions& options, const std::vector<std::string>& parts) {
  try {
    RunCaptureImpl(options);
    ADD_FAILURE() << "expected an error containing '" << parts.front() << "'";
  } catch (const Error& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos) << "'" << part << "' not in: " << message;
    }
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_FALSE(fs::exists(options.out)) << "half-written output left at " << options.out;
  for (const auto& entry : fs::directory_iterator(fs::path(options.out).parent_path())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos)
        << "temporary left behind: " << entry.path();
  }
}

constexpr int kOffsetSamples = 21922;  // 0.456708 s at 48 kHz

// Test inputs, made on first use (ctest runs each test in its own process).
class CaptureVideoTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = new TempDir("video"); }
  static void TearDownTestSuite() { delete dir_; }

  // The first 60 % of input `name`, as `cut_name`: a recording cut short.
  static std::string TruncatedCopy(const std::string& name, const std::string& cut_name) {
    const std::string cut = *dir_ / cut_name;
    fs::copy_file(In(name), cut, fs::copy_options::overwrite_existing);
    fs::resize_file(cut, fs::file_size(cut) * 6 / 10);
    return cut;
  }

  // The path of a named test input, encoding it if needed.
  static std::string In(const std::string& name) {
    const std::string path = *dir_ / name;
    if (fs::exists(path)) return path;
    const std::string room = *dir_ / "room.wav";
    if (!fs::exists(room)) MakeRoomSound(room, 10.0, 3);
    // Phone V hears the room from 2 s on; phone L started kOffset later (or earlier).
    if (name == "view.mp4") MakeVideo(path, 4.0, room, 2 * 48000);
    if (name == "light.mp4") MakeVideo(path, 4.0, room, 2 * 48000 + kOffsetSamples);
    if (name == "light_early.mp4") MakeVideo(path, 4.0, room, 2 * 48000 - kOffsetSamples);
    if (name == "unrelated.mp4") {
      MakeRoomSound(*dir_ / "other_room.wav", 10.0, 11);
      MakeVideo(path, 4.0, *dir_ / "other_room.wav", 2 * 48000);
    }
    if (name == "silent.mp4") MakeVideo(path, 4.0, "", 0);
    if (name == "moov_last.mp4") MakeVideo(path, 4.0, "", 0, /*faststart=*/false);
    EXPECT_TRUE(fs::exists(path)) << name;
    return path;
  }

  static TempDir* dir_;
};
TempDir* CaptureVideoTest::dir_ = nullptr;

TEST_F(CaptureVideoTest, AudioSyncRecoversOffsetOfEitherSign) {
  for (const auto& [light, sign] : {std::pair<std::string, int>{"light.mp4", 1}, {"light_early.mp4", -1}}) {
    const std::string out = *dir_ / ("out_" + light);
    const CaptureSummary summary = RunCaptureImpl(TestOptions(In("view.mp4"), In(light), out));
    const double truth = sign * kOffsetSamples / 48000.0;
    EXPECT_NEAR(summary.offset_s, truth, 0.5e-3) << light;
    const nlohmann::json capture = ReadCaptureJson(out);
    EXPECT_EQ(capture["sync"]["method"], "gcc-phat");
    EXPECT_NEAR(capture["sync"]["offset_s"].get<double>(), truth, 0.5e-3);
    EXPECT_GT(capture["sync"]["confidence"].get<double>(), 3.0);
    // Phone L frames are on phone V's clock: own time + offset.
    for (const auto& frame : capture["light_frames"]) {
      EXPECT_NEAR(frame["time_s"].get<double>(),
                  frame["source_time_s"].get<double>() + summary.offset_s, 1e-9);
    }
    // Each kept V frame lies between its first and last phone L frame.
    for (const auto& frame : capture["view_frames"]) {
      const auto& lights = frame["light_frames"];
      ASSERT_GE(lights.size(), 2u);
      const double t = frame["time_s"];
      EXPECT_LE(capture["light_frames"][lights.front().get<int>()]["time_s"].get<double>(), t);
      EXPECT_GE(capture["light_frames"][lights.back().get<int>()]["time_s"].get<double>(), t);
      EXPECT_TRUE(fs::exists(out + "/" + frame["image"].get<std::string>()));
      EXPECT_TRUE(fs::exists(out + "/" + frame["linear"].get<std::string>()));
    }
    EXPECT_TRUE(fs::exists(out + "/capture.log"));
    EXPECT_TRUE(fs::exists(out + "/run.json"));
  }
}

TEST_F(CaptureVideoTest, ManualOffsetOverridesAudio) {
  CaptureOptions o = TestOptions(In("view.mp4"), In("silent.mp4"), *dir_ / "out_manual");
  o.sync.offset_s = 0.25;
  const CaptureSummary summary = RunCaptureImpl(o);
  EXPECT_EQ(summary.sync_method, "manual");
  const nlohmann::json capture = ReadCaptureJson(o.out);
  EXPECT_EQ(capture["sync"]["offset_s"].get<double>(), 0.25);
  EXPECT_TRUE(capture["sync"]["confidence"].is_null());
}

// Frame budgets: phone L frames are kept only around kept phone V frames (and,
// with light_min_spacing_s, at most at that rate), each still bracketed as
// calib's light interpolation needs; the geometry pass follows its own target.
TEST_F(CaptureVideoTest, LightFramesFollowTheViewSelectionAndGeometryItsOwnTarget) {
  auto run = [&](const std::string& name, double spacing_s) {
    CaptureOptions o = TestOptions(In("view.mp4"), In("silent.mp4"), *dir_ / name);
    o.sync.offset_s = 0.25;
    o.view_select.target_frames = 100;  // most of the ~113 phone V frames inside phone L's recording
    o.light_min_spacing_s = spacing_s;
    o.geometry = In("light.mp4");
    o.geometry_select.target_frames = 7;
    RunCaptureImpl(o);
    return ReadCaptureJson(o.out);
  };
  const nlohmann::json all = run("out_budget_all", 0.0);
  const nlohmann::json thin = run("out_budget_thin", 0.06);
  for (const nlohmann::json* capture : {&all, &thin}) {
    const nlohmann::json& c = *capture;
    EXPECT_EQ(c["view_frames"].size(), 100u);
    EXPECT_EQ(c["geometry_frames"].size(), 7u);  // its own target, not phone V's
    std::set<int> used;
    for (const auto& frame : c["view_frames"]) {
      const double t = frame["time_s"];
      double before = -1e9, after = 1e9;
      for (const auto& l : frame["light_frames"]) {
        used.insert(l.get<int>());
        const double tl = c["light_frames"][l.get<int>()]["time_s"];
        if (tl <= t) before = std::max(before, tl);
        if (tl >= t) after = std::min(after, tl);
      }
      // calib's rule for a reliable light (light.max_gap_s 0.05 s): nearest
      // phone L frame within 0.05 s, the two around it within 0.1 s.
      EXPECT_LE(std::min(t - before, after - t), 0.05) << t;
      EXPECT_LE(after - before, 0.1 + 1e-9) << t;
    }
    // Every kept phone L frame places the flash of some kept phone V frame.
    EXPECT_EQ(used.size(), c["light_frames"].size());
    EXPECT_EQ(c["counts"]["light_kept"].get<size_t>(), c["light_frames"].size());
  }
  EXPECT_EQ(all["counts"]["light_candidates"], all["counts"]["light_usable"]);
  EXPECT_LT(thin["counts"]["light_candidates"].get<int>(), all["counts"]["light_candidates"].get<int>() * 0.55);
  EXPECT_LT(thin["light_frames"].size(), all["light_frames"].size() * 0.55);
  EXPECT_GT(thin["light_frames"].size(), all["light_frames"].size() * 0.4);
}

TEST_F(CaptureVideoTest, RefusesUnrelatedRecordings) {
  ExpectFailure(TestOptions(In("view.mp4"), In("unrelated.mp4"), *dir_ / "out_unrelated"),
                {"confidence", "sync.min_confidence", "--offset-s"});
}

TEST_F(CaptureVideoTest, RefusesVideoWithoutAudioWhenAutoSyncing) {
  ExpectFailure(TestOptions(In("view.mp4"), In("silent.mp4"), *dir_ / "out_silent"),
                {"silent.mp4", "no audio track", "--offset-s"});
}

TEST_F(CaptureVideoTest, RefusesMissingFile) {
  ExpectFailure(TestOptions(In("view.mp4"), *dir_ / "nowhere.mp4", *dir_ / "out_missing"),
                {"nowhere.mp4", "no such file", "--light"});
}

TEST_F(CaptureVideoTest, RefusesFileThatIsNotAVideo) {
  { std::ofstream(*dir_ / "notes.mp4") << "not a video\n"; }
  ExpectFailure(TestOptions(*dir_ / "notes.mp4", In("light.mp4"), *dir_ / "out_notes"),
                {"notes.mp4", "truncated or not a video", "--view"});
}

TEST_F(CaptureVideoTest, RefusesTruncatedFileWithoutIndex) {
  CaptureOptions o = TestOptions(TruncatedCopy("moov_last.mp4", "moov_cut.mp4"), In("light.mp4"), *dir_ / "out_moov_cut");
  o.sync.offset_s = 0.0;
  ExpectFailure(o, {"moov_cut.mp4", "truncated or not a video"});
}

TEST_F(CaptureVideoTest, TruncatedStreamNeedsAllowPartial) {
  CaptureOptions o = TestOptions(TruncatedCopy("view.mp4", "view_cut.mp4"), In("light.mp4"), *dir_ / "out_cut");
  o.sync.offset_s = 0.0;
  ExpectFailure(o, {"view_cut.mp4", "decode error at t =", "--allow-partial"});

  o.allow_partial = true;
  o.view_select.target_frames = 1000;
  RunCaptureImpl(o);
  const nlohmann::json capture = ReadCaptureJson(o.out);
  const auto& error = capture["inputs"]["view"]["decode_error"];
  ASSERT_TRUE(error.is_object());
  const int before = error["frames_before"];
  EXPECT_GT(before, 10);
  EXPECT_LT(before, 120);
  EXPECT_EQ(capture["inputs"]["view"]["frames_usable"].get<int>(), before);
  for (const auto& frame : capture["view_frames"]) {
    EXPECT_LT(frame["source_frame"].get<int>(), before);
    EXPECT_LE(frame["time_s"].get<double>(), error["time_s"].get<double>());
  }
}

TEST_F(CaptureVideoTest, RefusesVideosThatDoNotOverlap) {
  CaptureOptions o = TestOptions(In("view.mp4"), In("light.mp4"), *dir_ / "out_apart");
  o.sync.offset_s = 30.0;
  ExpectFailure(o, {"do not overlap", "--offset-s"});
}

TEST_F(CaptureVideoTest, RefusesWhenNoFrameIsLeft) {
  const std::string black = *dir_ / "black.mp4";
  Shell("ffmpeg -nostdin -v error -y -f lavfi -i color=c=black:size=160x120:rate=30:d=1 "
        "-c:v libx264 -pix_fmt yuv420p " + black);
  CaptureOptions o = TestOptions(black, In("light.mp4"), *dir_ / "out_black");
  o.sync.offset_s = 0.0;
  ExpectFailure(o, {"no phone V frame left", "dark", "view_select"});
}

TEST_F(CaptureVideoTest, RefusesAbsurdOptions) {
  CaptureOptions o = TestOptions(*dir_ / "view.mp4", *dir_ / "light.mp4", *dir_ / "out_absurd");
  o.view_select.target_frames = -3;
  ExpectFailure(o, {"target_frames"});
  o = TestOptions(*dir_ / "view.mp4", *dir_ / "light.mp4", *dir_ / "out_absurd");
  o.sync.max_offset_s = 0;
  ExpectFailure(o, {"max_offset_s"});
  o = TestOptions(*dir_ / "view.mp4", *dir_ / "light.mp4", *dir_ / "out_absurd");
  o.transfer = "linear-ish";
  ExpectFailure(o, {"--transfer"});
  o = TestOptions(*dir_ / "view.mp4", *dir_ / "light.mp4", *dir_ / "out_absurd");
  o.max_long_side_px = 3;
  ExpectFailure(o, {"max_long_side_px"});
}

// Inputs that cannot make a capture and outputs that would lose the user's
// files (docs/refusals.md): each is refused and leaves every file as it was.
TEST_F(CaptureVideoTest, RefusesOutputsThatWouldLoseFilesAndInputsThatFakeACapture) {
  auto error_of = [](const CaptureOptions& o) {
    try {
      RunCaptureImpl(o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  auto read = [](const fs::path& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const fs::path user = *dir_ / "user";
  fs::create_directories(user);
  fs::copy_file(In("view.mp4"), user / "v.mp4", fs::copy_options::overwrite_existing);
  fs::copy_file(In("light.mp4"), user / "l.mp4", fs::copy_options::overwrite_existing);
  std::ofstream(user / "notes.txt") << "mine";
  // --out is the folder holding the inputs (also with --force).
  CaptureOptions o = TestOptions(user / "v.mp4", user / "l.mp4", user);
  o.force = true;
  EXPECT_NE(error_of(o).find("holds the input"), std::string::npos) << error_of(o);
  EXPECT_EQ(read(user / "notes.txt"), "mine");
  EXPECT_TRUE(fs::exists(user / "v.mp4"));
  // --out is an existing file.
  o = TestOptions(user / "v.mp4", user / "l.mp4", user / "notes.txt");
  EXPECT_NE(error_of(o).find("never replaces a file"), std::string::npos) << error_of(o);
  EXPECT_EQ(read(user / "notes.txt"), "mine");
  // A folder of someone else's files without --force.
  o = TestOptions(In("view.mp4"), In("light.mp4"), user);
  o.sync.offset_s = 0.0;
  EXPECT_NE(error_of(o).find("--force"), std::string::npos) << error_of(o);
  // One video as both phones (the same path, or a copy).
  o = TestOptions(In("view.mp4"), In("view.mp4"), *dir_ / "out_same");
  EXPECT_NE(error_of(o).find("same file"), std::string::npos) << error_of(o);
  o = TestOptions(In("view.mp4"), user / "v.mp4", *dir_ / "out_same");
  o.sync.offset_s = 0.0;
  EXPECT_NE(error_of(o).find("same video"), std::string::npos) << error_of(o);
  // A folder, and a still image renamed .mp4, as videos.
  o = TestOptions(user.string(), In("light.mp4"), *dir_ / "out_folder");
  EXPECT_NE(error_of(o).find("is a folder"), std::string::npos) << error_of(o);
  cv::imwrite(*dir_ / "still.png", cv::Mat(64, 64, CV_8UC3, cv::Scalar(40, 80, 120)));
  fs::copy_file(*dir_ / "still.png", *dir_ / "still.mp4", fs::copy_options::overwrite_existing);
  o = TestOptions(*dir_ / "still.mp4", In("light.mp4"), *dir_ / "out_still");
  o.sync.offset_s = 0.0;
  EXPECT_NE(error_of(o).find("still image"), std::string::npos) << error_of(o);
  EXPECT_FALSE(fs::exists(*dir_ / "out_still"));
}

}  // namespace
}  // namespace relit::capture
