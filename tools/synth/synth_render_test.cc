// Renders the tiny preset once and checks the capture against its ground
// truth: audio offset, board corners, alpha mattes, determinism, eval set.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "core/board.h"
#include "core/json_file.h"
#include "core/median.h"
#include "core/render/mesh.h"
#include "core/test_dir.h"
#include "tools/synth/audio.h"
#include "tools/synth/ffmpeg_io.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

namespace relit::synth {
namespace {

namespace fs = std::filesystem;

// The capture these tests check: tiny size, spot preset, seed 7, into `out`.
SynthOptions TinySpotSeed7(const fs::path& out) {
  SynthOptions options = SynthOptions::ForSize("tiny");
  options.preset = "spot";
  options.seed = 7;
  options.out = out.string();
  return options;
}

class SynthRenderTest : public ::testing::Test {
 protected:
  // CTest runs every TEST in its own process (gtest_discover_tests), so the
  // tiny capture is rendered once per test binary build and shared through a
  // cache directory keyed by the binary's size and modification time; a file
  // lock makes concurrent test processes wait for the one that renders.
  static void SetUpTestSuite() {
    root_ = new fs::path(fs::temp_directory_path() /
                         ("relit_synth_test_" + std::to_string(::getpid())));
    fs::create_directories(*root_);
    const char* existing = std::getenv("RELIT_SYNTH_TEST_CAPTURE");
    if (existing != nullptr && *existing != '\0') {
      // Developers: reuse an existing tiny spot seed-7 render.
      capture_ = new fs::path(fs::absolute(existing));
      summary_ = new SynthSummary();
    } else {
      const test_support::BuildCache build_cache = test_support::TestBuildCache("relit_synth_test_cache_");
      const fs::path& cache = build_cache.dir;
      const std::string key = "tiny_spot_7_" + build_cache.build_key;
      capture_ = new fs::path(cache / key);
      const int lock = ::open((cache / (key + ".lock")).c_str(), O_CREAT | O_RDWR, 0644);
      ASSERT_GE(lock, 0);
      ASSERT_EQ(::flock(lock, LOCK_EX), 0);
      if (!fs::exists(*capture_ / "truth.json")) {
        for (const auto& entry : fs::directory_iterator(cache)) {  // captures of older builds
          if (entry.path().filename().string().rfind("tiny_spot_7_", 0) == 0 &&
              entry.path().filename().string().rfind(key, 0) != 0) {
            std::error_code ignored;
            fs::remove_all(entry.path(), ignored);
          }
        }
        summary_ = new SynthSummary(RunSynthImpl(TinySpotSeed7(*capture_)));
      } else {
        summary_ = new SynthSummary();
      }
      ::flock(lock, LOCK_UN);
      ::close(lock);
    }
    truth_ = new nlohmann::json(
        ReadJsonFile((*capture_ / "truth.json").string(), kTruthKind, kTruthVersion));
  }
  static void TearDownTestSuite() {
    std::error_code ignored;
    fs::remove_all(*root_, ignored);
    delete truth_;
    delete summary_;
    delete capture_;
    delete root_;
  }
  static fs::path Capture(const std::string& relative) { return *capture_ / relative; }
  static Camera FrameCamera(const std::string& video, int frame) {
    const nlohmann::json& v = (*truth_)["videos"][video];
    return Camera(IntrinsicsFromJson(v["intrinsics"]),
                  Rigid3FromJson(v["frames"][frame]["cam_from_world"]));
  }
  static BoardSpec Board() {
    const nlohmann::json& b = (*truth_)["board"];
    BoardSpec spec;
    spec.squares_x = b["squares_x"];
    spec.squares_y = b["squares_y"];
    spec.square_length_m = b["square_length_m"];
    spec.marker_length_m = b["marker_length_m"];
    spec.dictionary = b["dictionary"];
    return spec;
  }

  static fs::path* root_;     // per-process scratch directory
  static fs::path* capture_;  // the shared tiny render
  static SynthSummary* summary_;
  static nlohmann::json* truth_;
};
fs::path* SynthRenderTest::root_ = nullptr;
fs::path* SynthRenderTest::capture_ = nullptr;
SynthSummary* SynthRenderTest::summary_ = nullptr;
nlohmann::json* SynthRenderTest::truth_ = nullptr;

TEST_F(SynthRenderTest, VideosHaveTheAdvertisedFormat) {
  if (summary_->seconds > 0) std::printf("tiny spot render took %.1f s\n", summary_->seconds);
  // The tiny preset's two phones differ (synth_options.cc TwoDifferentPhones).
  const std::map<std::string, std::vector<double>> expected = {
      // width, height, fps, frames, audio rate, audio start
      {"view", {320, 240, 30.0, 30, 48000, -0.021}},
      {"light", {352, 264, 30000.0 / 1001, 33, 44100, 0.034}}};
  for (const auto& [name, e] : expected) {
    const MediaInfo info = ProbeMedia(Capture(name + ".mp4").string());
    const nlohmann::json& video = (*truth_)["videos"][name];
    EXPECT_EQ(info.video_codec, "h264") << name;
    EXPECT_EQ(info.pix_fmt, "yuv420p") << name;
    EXPECT_EQ(info.color_transfer, "iec61966-2-1") << name;
    EXPECT_EQ(info.width_px, e[0]) << name;
    EXPECT_EQ(info.height_px, e[1]) << name;
    EXPECT_NEAR(info.fps, e[2], 1e-6) << name;
    EXPECT_EQ(info.frame_count, e[3]) << name;
    EXPECT_EQ(info.audio_sample_rate_hz, e[4]) << name;
    EXPECT_EQ(video["frames"].size(), static_cast<size_t>(e[3])) << name;
    EXPECT_EQ(video["intrinsics"]["width"].get<int>(), e[0]) << name;
    EXPECT_NEAR(video["audio_start_own_s"].get<double>(), e[5], 1e-12) << name;
    EXPECT_NEAR(video["rolling_shutter_s"].get<double>(), 0.001, 1e-12) << name;
  }
  // Phone L's auto-exposure drifts by up to 15 %, phone V's is fixed.
  double low = 2, high = 0;
  for (const auto& frame : (*truth_)["videos"]["light"]["frames"]) {
    low = std::min(low, frame["exposure_scale"].get<double>());
    high = std::max(high, frame["exposure_scale"].get<double>());
  }
  EXPECT_GE(low, 0.85 - 1e-9);
  EXPECT_LE(high, 1.15 + 1e-9);
  EXPECT_GT(high - low, 0.1);
  EXPECT_FALSE((*truth_)["videos"]["view"]["frames"][0].contains("exposure_scale"));
}

TEST_F(SynthRenderTest, AudioOffsetEqualsTruth) {
  const std::vector<float> view = DecodeAudio(Capture("view.mp4").string(), 48000);
  const std::vector<float> light = DecodeAudio(Capture("light.mp4").string(), 48000);
  ASSERT_GT(view.size(), 40000u);
  ASSERT_GT(light.size(), 40000u);
  const double truth_offset_s = (*truth_)["light_start_offset_s"];
  // The decoded tracks start at their first decoded sample, not at their
  // videos' first frames: view[n] hears what light hears (offset + light's
  // audio start - view's audio start, each relative to its first frame)
  // seconds later in its own track. AAC priming left undecoded by an
  // offset track shows up in its start time.
  const MediaInfo view_info = ProbeMedia(Capture("view.mp4").string());
  const MediaInfo light_info = ProbeMedia(Capture("light.mp4").string());
  const double track_lag_s = truth_offset_s + (light_info.audio_start_s - light_info.video_start_s) -
                             (view_info.audio_start_s - view_info.video_start_s);
  std::printf("audio starts after the first frame: view %+.4f s (truth %+.4f), light %+.4f s (truth %+.4f, "
              "AAC priming %.4f s)\n", view_info.audio_start_s - view_info.video_start_s,
              (*truth_)["videos"]["view"]["audio_start_own_s"].get<double>(),
              light_info.audio_start_s - light_info.video_start_s,
              (*truth_)["videos"]["light"]["audio_start_own_s"].get<double>(), 1024.0 / 44100);
  const double lag_s = CrossCorrelationLagS(view, light, 48000, 3.5);
  std::printf("audio track lag: truth %+.6f s, measured %+.6f s, error %.3f ms\n", track_lag_s,
              lag_s, 1e3 * std::abs(lag_s - track_lag_s));
  EXPECT_NEAR(lag_s, track_lag_s, 1e-3);
  EXPECT_GE(std::abs(truth_offset_s), 0.2);
  EXPECT_LE(std::abs(truth_offset_s), 0.5);
}

// Detects ChArUco corners in decoded video frames and compares them with the
// ground-truth corners projected by the ground-truth cameras.
void CheckBoardCorners(const std::string& video_name, const fs::path& mp4, const BoardSpec& spec,
                       const std::function<Camera(int)>& camera_of) {
  const auto board = MakeCharucoBoard(spec);
  const auto corners_world = CharucoCornersWorld(spec);
  const DecodedVideo video = DecodeVideo(mp4.string(), /*grey=*/true);
  ASSERT_GT(video.frames.size(), 0u);
  std::vector<double> errors;
  Eigen::Vector2d mean_residual = Eigen::Vector2d::Zero();
  int frames_with_corners = 0;
  auto parameters = cv::aruco::DetectorParameters::create();
  for (size_t f = 0; f < video.frames.size(); ++f) {
    const cv::Mat grey(video.height_px, video.width_px, CV_8UC1,
                       const_cast<uint8_t*>(video.frames[f].data()));
    std::vector<int> marker_ids;
    std::vector<std::vector<cv::Point2f>> marker_corners;
    cv::aruco::detectMarkers(grey, board->dictionary, marker_corners, marker_ids, parameters);
    if (marker_ids.size() < 2) continue;
    std::vector<cv::Point2f> charuco_corners;
    std::vector<int> charuco_ids;
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, grey, board, charuco_corners,
                                         charuco_ids);
    if (charuco_ids.size() < 4) continue;
    // OpenCV 4.6's own refinement inside interpolateCornersCharuco stops at
    // 0.1 px steps and keeps the ~0.5 px bias of the contour-based marker
    // corners; a converged cornerSubPix removes it.
    cv::cornerSubPix(grey, charuco_corners, cv::Size(3, 3), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-3));
    ++frames_with_corners;
    const Camera camera = camera_of(static_cast<int>(f));
    for (size_t k = 0; k < charuco_ids.size(); ++k) {
      Eigen::Vector2d projected;
      ASSERT_TRUE(camera.Project(corners_world[charuco_ids[k]], &projected));
      const Eigen::Vector2d residual(charuco_corners[k].x - projected.x(),
                                     charuco_corners[k].y - projected.y());
      errors.push_back(residual.norm());
      mean_residual += residual;
    }
  }
  ASSERT_FALSE(errors.empty()) << video_name << ": no ChArUco corner found";
  const double median = Median(errors);
  mean_residual /= std::max<size_t>(1, errors.size());
  std::printf("%s: ChArUco corners in %d/%zu frames, %zu corners, median error %.3f px, "
              "mean residual (detected - projected) (%+.3f, %+.3f) px\n",
              video_name.c_str(), frames_with_corners, video.frames.size(), errors.size(), median,
              mean_residual.x(), mean_residual.y());
  EXPECT_GE(frames_with_corners, static_cast<int>(video.frames.size()) / 2) << video_name;
  EXPECT_LT(median, 0.5) << video_name;
}

TEST_F(SynthRenderTest, BoardCornersLandOnProjectedGroundTruth) {
  CheckBoardCorners("view.mp4", Capture("view.mp4"), Board(),
                    [](int f) { return FrameCamera("view", f); });
  CheckBoardCorners("light.mp4", Capture("light.mp4"), Board(),
                    [](int f) { return FrameCamera("light", f); });
}

// 4x4 supersampled coverage of the ground-truth meshes seen by `camera`.
cv::Mat RasteriseCoverage(const std::vector<render::TriangleMesh>& meshes, const Camera& camera) {
  const int s = 4;
  const Intrinsics& k = camera.intrinsics();
  cv::Mat fine = cv::Mat::zeros(k.height * s, k.width * s, CV_8UC1);
  constexpr int kShift = 8;
  for (const render::TriangleMesh& mesh : meshes) {
    std::vector<cv::Point> projected(mesh.positions.size());
    std::vector<bool> valid(mesh.positions.size());
    for (size_t i = 0; i < mesh.positions.size(); ++i) {
      Eigen::Vector2d p;
      valid[i] = camera.Project(mesh.positions[i].cast<double>(), &p);
      // Fine pixel centres are integers: x_fine = s * (x + 0.5) - 0.5.
      projected[i] = cv::Point(static_cast<int>(std::lround((s * (p.x() + 0.5) - 0.5) * (1 << kShift))),
                               static_cast<int>(std::lround((s * (p.y() + 0.5) - 0.5) * (1 << kShift))));
    }
    for (const Eigen::Vector3i& t : mesh.triangles) {
      if (!valid[t[0]] || !valid[t[1]] || !valid[t[2]]) continue;
      const cv::Point triangle[3] = {projected[t[0]], projected[t[1]], projected[t[2]]};
      cv::fillConvexPoly(fine, triangle, 3, cv::Scalar(255), cv::LINE_8, kShift);
    }
  }
  cv::Mat coarse;
  cv::resize(fine, coarse, cv::Size(k.width, k.height), 0, 0, cv::INTER_AREA);
  coarse.convertTo(coarse, CV_32F, 1.0 / 255.0);
  return coarse;
}

TEST_F(SynthRenderTest, MattesAgreeWithMeshProjection) {
  std::vector<render::TriangleMesh> meshes;
  for (const auto& object : (*truth_)["objects"]) {
    meshes.push_back(render::LoadMesh(Capture(object["mesh"].get<std::string>()).string()));
  }
  ASSERT_FALSE(meshes.empty());
  const auto& frames = (*truth_)["videos"]["view"]["frames"];
  double worst_iou = 1, sum_iou = 0;
  int checked = 0;
  for (size_t f = 0; f < frames.size(); f += 5) {
    const Image alpha = ReadImage(Capture(frames[f]["alpha"].get<std::string>()).string());
    const cv::Mat coverage = RasteriseCoverage(meshes, FrameCamera("view", static_cast<int>(f)));
    ASSERT_EQ(alpha.width(), coverage.cols);
    ASSERT_EQ(alpha.height(), coverage.rows);
    // Soft IoU of the fractional coverages (4 spp alpha vs 16x supersampled raster).
    double intersection = 0, uni = 0;
    for (int y = 0; y < alpha.height(); ++y) {
      for (int x = 0; x < alpha.width(); ++x) {
        const double a = alpha.at(x, y, 0), b = coverage.at<float>(y, x);
        intersection += std::min(a, b);
        uni += std::max(a, b);
      }
    }
    ASSERT_GT(uni, 100) << "frame " << f << ": object hardly visible";
    const double iou = intersection / uni;
    worst_iou = std::min(worst_iou, iou);
    sum_iou += iou;
    ++checked;
  }
  std::printf("mattes vs mesh projection: %d frames, mean IoU %.4f, worst %.4f\n", checked,
              sum_iou / checked, worst_iou);
  EXPECT_GT(worst_iou, 0.95);
}

TEST_F(SynthRenderTest, TruthIsDeterministicForASeed) {
  SynthOptions options = TinySpotSeed7(*root_ / "again");
  options.truth_only = true;
  RunSynthImpl(options);
  nlohmann::json again = ReadJsonFile(options.out + "/truth.json", kTruthKind, kTruthVersion);
  nlohmann::json first = *truth_;
  EXPECT_TRUE(first["rendered"].get<bool>());
  EXPECT_TRUE(first["videos_rendered"].get<bool>());
  EXPECT_FALSE(again["rendered"].get<bool>());
  EXPECT_FALSE(again["videos_rendered"].get<bool>());
  for (const char* key : {"rendered", "videos_rendered"}) {
    first.erase(key);
    again.erase(key);
  }
  EXPECT_EQ(first.dump(), again.dump());

  options.seed = 8;
  options.out = (*root_ / "other").string();
  RunSynthImpl(options);
  const nlohmann::json other = ReadJsonFile(options.out + "/truth.json", kTruthKind, kTruthVersion);
  EXPECT_NE(other["light_start_offset_s"], first["light_start_offset_s"]);
  EXPECT_NE(other["videos"]["view"]["frames"][0]["cam_from_world"],
            first["videos"]["view"]["frames"][0]["cam_from_world"]);
}

TEST_F(SynthRenderTest, EvalSetIsComplete) {
  const nlohmann::json& eval = (*truth_)["eval"];
  const Intrinsics k = IntrinsicsFromJson(eval["intrinsics"]);
  EXPECT_TRUE(k.distortion.IsZero());
  ASSERT_EQ(eval["views"].size(), 3u);  // tiny: 2 extrapolation + 1 interpolation
  std::set<std::string> types;
  for (const auto& light : eval["lights"]) types.insert(light["type"].get<std::string>());
  EXPECT_EQ(types, (std::set<std::string>{"point", "directional", "environment"}));
  for (const auto& light : eval["lights"]) {
    if (light["type"] == "environment") {
      const Image map = ReadImage(Capture(light["envmap"].get<std::string>()).string());
      EXPECT_EQ(map.width(), 2 * map.height());
    }
  }
  int interpolation = 0;
  for (const auto& view : eval["views"]) {
    if (view["set"] == "interpolation") {
      // On phone V's path between its frames: close to a training view, yet no frame's pose.
      ++interpolation;
      EXPECT_LT(view["min_angle_to_training_views_rad"].get<double>(), 5.0 * M_PI / 180);
      for (const auto& frame : (*truth_)["videos"]["view"]["frames"]) {
        EXPECT_NE(frame["cam_from_world"], view["cam_from_world"]);
      }
    } else {
      EXPECT_EQ(view["set"], "extrapolation");
      EXPECT_GE(view["min_angle_to_training_views_rad"].get<double>(), 10.0 * M_PI / 180 - 1e-9);
    }
    // The noise half (the image is its mean with an independent other half):
    // same size, not the same pixels.
    ASSERT_TRUE(view.contains("images_half"));
    for (const auto& [light, path] : view["images_half"].items()) {
      const Image twin = ReadImage(Capture(path.get<std::string>()).string());
      const Image image = ReadImage(Capture(view["images"][light].get<std::string>()).string());
      ASSERT_EQ(twin.data().size(), image.data().size());
      EXPECT_NE(twin.data(), image.data()) << light;
    }
    const Image alpha = ReadImage(Capture(view["alpha"].get<std::string>()).string());
    EXPECT_EQ(alpha.width(), k.width);
    double covered = 0;
    for (float a : alpha.data()) covered += a;
    EXPECT_GT(covered, 100) << "object not in held-out view " << view["name"];
    for (const auto& [light, path] : view["images"].items()) {
      const Image image = ReadImage(Capture(path.get<std::string>()).string());
      EXPECT_EQ(image.width(), k.width);
      EXPECT_EQ(image.height(), k.height);
      // The object is lit: its mean radiance is neither black nor blown out.
      double sum = 0, weight = 0;
      for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
          const float a = alpha.at(x, y, 0);
          sum += a * (image.at(x, y, 0) + image.at(x, y, 1) + image.at(x, y, 2)) / 3;
          weight += a;
        }
      }
      const double mean = sum / weight;
      EXPECT_GT(mean, 0.01) << light;
      EXPECT_LT(mean, 2.0) << light;
    }
  }
  EXPECT_EQ(interpolation, 1);
}

// --eval-only renders the same eval set as the full run (same options, seed
// 7): same truth plan, and bit-equal pixels because every image has its own
// seed stream. No videos or mattes are written.
TEST_F(SynthRenderTest, EvalOnlyEqualsTheFullRunsEvalSet) {
  SynthOptions options = TinySpotSeed7(*root_ / "eval_only");
  options.eval_only = true;
  const SynthSummary summary = RunSynthImpl(options);
  const fs::path out(options.out);
  EXPECT_EQ(summary.frames_rendered, 0);
  EXPECT_FALSE(fs::exists(out / "view.mp4"));
  EXPECT_FALSE(fs::exists(out / "light.mp4"));
  EXPECT_FALSE(fs::exists(out / "truth/view_alpha"));

  nlohmann::json eval_only = ReadJsonFile((out / "truth.json").string(), kTruthKind, kTruthVersion);
  nlohmann::json full = *truth_;
  EXPECT_TRUE(eval_only["rendered"].get<bool>());  // relit-relight eval accepts it
  EXPECT_FALSE(eval_only["videos_rendered"].get<bool>());
  EXPECT_TRUE(full["videos_rendered"].get<bool>());
  eval_only.erase("videos_rendered");
  full.erase("videos_rendered");
  EXPECT_EQ(eval_only.dump(), full.dump());  // same cameras, lights, paths

  std::vector<std::string> files;
  for (const auto& light : full["eval"]["lights"]) {
    if (light["type"] == "environment") files.push_back(light["envmap"]);
  }
  for (const auto& view : full["eval"]["views"]) {
    files.push_back(view["alpha"]);
    for (const auto& [name, path] : view["images"].items()) files.push_back(path);
  }
  EXPECT_EQ(summary.eval_images, static_cast<int>(full["eval"]["views"].size() *
                                                  full["eval"]["lights"].size()));
  for (const std::string& file : files) {
    const Image a = ReadImage((out / file).string());
    const Image b = ReadImage(Capture(file).string());
    ASSERT_EQ(a.width(), b.width()) << file;
    ASSERT_EQ(a.height(), b.height()) << file;
    ASSERT_EQ(a.channels(), b.channels()) << file;
    size_t differing = 0;
    for (size_t i = 0; i < a.data().size(); ++i) differing += a.data()[i] != b.data()[i];
    EXPECT_EQ(differing, 0u) << file << ": eval-only pixels differ from the full run's";
  }
}

// eval_environment_samples_per_pixel raises the samples of the map-lit
// images only: the point and directional images are the default run's to
// the bit, and a map-lit image's noise (its difference from its kept half,
// over the foreground) falls by about sqrt(8) at 8x the samples.
TEST_F(SynthRenderTest, EnvironmentSamplesLowerOnlyTheMapsNoise) {
  SynthOptions options = TinySpotSeed7(*root_ / "environment_spp");
  options.eval_only = true;
  options.eval_environment_samples_per_pixel = 8 * options.eval_samples_per_pixel;
  RunSynthImpl(options);
  const fs::path out(options.out);
  const nlohmann::json truth = ReadJsonFile((out / "truth.json").string(), kTruthKind, kTruthVersion);
  EXPECT_EQ(truth["render"]["eval_environment_samples_per_pixel"].get<int>(), 8 * options.eval_samples_per_pixel);
  std::map<std::string, std::string> type_of;
  for (const auto& light : truth["eval"]["lights"]) type_of[light["name"]] = light["type"];
  // Foreground RMS of image - half, one image.
  auto noise = [](const fs::path& image_path, const fs::path& half_path, const Image& alpha) {
    const Image image = ReadImage(image_path.string()), half = ReadImage(half_path.string());
    double sum = 0;
    int64_t count = 0;
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        if (alpha.at(x, y, 0) < 0.5f) continue;
        for (int c = 0; c < 3; ++c) sum += std::pow(image.at(x, y, c) - half.at(x, y, c), 2);
        count += 3;
      }
    }
    return std::sqrt(sum / std::max<int64_t>(count, 1));
  };
  int maps = 0;
  for (const auto& view : truth["eval"]["views"]) {
    const Image alpha = ReadImage(Capture(view["alpha"].get<std::string>()).string());
    for (const auto& [light, path] : view["images"].items()) {
      const std::string half = view["images_half"][light].get<std::string>();
      const Image ours = ReadImage((out / path.get<std::string>()).string());
      const Image theirs = ReadImage(Capture(path.get<std::string>()).string());
      ASSERT_EQ(ours.data().size(), theirs.data().size());
      if (type_of[light] != "environment") {
        EXPECT_TRUE(ours.data() == theirs.data()) << path << ": a point or directional image changed";
        continue;
      }
      ++maps;
      const double more = noise(out / path.get<std::string>(), out / half, alpha);
      const double fewer = noise(Capture(path.get<std::string>()), Capture(half), alpha);
      EXPECT_LT(more, fewer / 2) << path;
      EXPECT_GT(more, fewer / 5) << path;
    }
  }
  EXPECT_GT(maps, 0);
}

// Eval images take the eval samples only in the box where the foreground
// projects (eval_background_samples_per_pixel elsewhere; tiny: 8 and 4):
// there the image's two noise halves have their own samples, outside they
// share the background's. So every foreground pixel differs between the
// image and its kept half, and the pixels that differ lie in a box smaller
// than the frame.
TEST_F(SynthRenderTest, EvalSamplesCoverTheForegroundAndSpareTheBackground) {
  size_t foreground = 0, foreground_differing = 0;
  double smallest_box_fraction = 1;
  for (const auto& view : (*truth_)["eval"]["views"]) {
    const Image alpha = ReadImage(Capture(view["alpha"].get<std::string>()).string());
    int x0 = alpha.width(), y0 = alpha.height(), x1 = -1, y1 = -1;  // where image and half differ
    for (const auto& [light, path] : view["images"].items()) {
      const Image image = ReadImage(Capture(path.get<std::string>()).string());
      const Image twin = ReadImage(Capture(view["images_half"][light].get<std::string>()).string());
      for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
          bool equal = true;
          for (int c = 0; c < 3; ++c) equal = equal && image.at(x, y, c) == twin.at(x, y, c);
          if (!equal) x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
          if (alpha.at(x, y, 0) > 0.01f) {
            ++foreground;
            foreground_differing += !equal;
          }
        }
      }
    }
    const double box = x1 < 0 ? 0.0 : double(x1 - x0 + 1) * (y1 - y0 + 1);
    smallest_box_fraction = std::min(smallest_box_fraction, box / (alpha.width() * alpha.height()));
  }
  ASSERT_GT(foreground, 1000u);
  // Not every one: at tiny's 4 spp per half, both halves of a pixel can agree
  // to half-float precision (1.6 % of them do, shadowed ones mostly).
  EXPECT_GE(foreground_differing, 0.97 * foreground) << "foreground pixels outside the eval-sample box";
  EXPECT_LT(smallest_box_fraction, 0.9) << "the background took the eval samples too";
}

}  // namespace
}  // namespace relit::synth
