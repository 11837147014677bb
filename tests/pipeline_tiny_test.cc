// End to end: the tiny synthetic spot capture (relit-synth) through the real
// stage executables, chained by the orchestrator (`relit run`). Checks the
// outputs each stage must leave, the lock file, that a second run does
// nothing and that a relight parameter edit reruns only what follows it.
//
// The relight part needs relit-relight (and report relit-report); when the
// build has no such target the test stops after reconstruct and says so.
// RELIT_PIPELINE_TEST_SYNTH=DIR reuses an existing
// `relit-synth --preset spot --size tiny --seed 1 --out DIR` render.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "core/image.h"
#include "core/json_file.h"
#include "core/render/mesh.h"
#include "core/shell.h"
#include "core/workspace.h"
#include "pipeline/runner.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"
#ifdef RELIT_HAVE_RELIGHT_LADDER
#include "bench/relight_ladder.h"
#include "calib/truth_accuracy.h"
#endif

namespace relit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

#ifdef RELIT_RELIGHT_EXE
constexpr const char* kRelight = RELIT_RELIGHT_EXE;
#else
constexpr const char* kRelight = "";
#endif
#ifdef RELIT_REPORT_EXE
constexpr const char* kReport = RELIT_REPORT_EXE;
#else
constexpr const char* kReport = "";
#endif

class PipelineTinyTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("relit_pipeline_tiny_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    synth_ = new fs::path(*dir_ / "synth");
    if (const char* reuse = std::getenv("RELIT_PIPELINE_TEST_SYNTH")) {
      *synth_ = reuse;
    } else {
      synth::SynthOptions o = synth::SynthOptions::ForSize("tiny");
      o.preset = "spot";
      o.seed = 1;
      o.out = synth_->string();
      o.eval_views = 1;
      o.eval_samples_per_pixel = 1;
      synth::RunSynthImpl(o);
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete synth_;
  }

  // pipeline.yaml for the tiny capture: the truth's board, the truth mesh as
  // proxy (reconstruct's own proxy is tested by its stage), small settings.
  static fs::path WritePipeline(const std::string& relight_train_steps) {
    const json truth = ReadJsonFile((*synth_ / "truth.json").string(), synth::kTruthKind, synth::kTruthVersion);
    const json& board = truth["board"];
    std::ostringstream yaml;
    yaml << "inputs:\n"
         << "  view: " << (*synth_ / "view.mp4").string() << "\n"
         << "  light: " << (*synth_ / "light.mp4").string() << "\n"
         << "  proxy_mesh: " << (*synth_ / truth["objects"][0]["mesh"].get<std::string>()).string() << "\n"
         << "  truth: " << (*synth_ / "truth.json").string() << "\n"
         << "board: {squares_x: " << board["squares_x"] << ", squares_y: " << board["squares_y"]
         << ", square_length_m: " << board["square_length_m"].get<double>()
         << ", marker_length_m: " << board["marker_length_m"].get<double>()
         << ", dictionary: " << board["dictionary"].get<std::string>() << "}\n"
         << "tools:\n"
         << "  capture: " << RELIT_CAPTURE_EXE << "\n"
         << "  calib: " << RELIT_CALIB_EXE << "\n"
         << "  reconstruct: " << RELIT_RECONSTRUCT_EXE << "\n";
    if (*kRelight) yaml << "  relight: " << kRelight << "\n";
    if (*kReport) yaml << "  report: " << kReport << "\n";
    yaml << "capture: {view_select: {target_frames: 1000}}\n"
         << "calib: {sfm: {enabled: false}}\n"
         << "reconstruct: {atlas: {resolution_px: 256}}\n"
         << "relight:\n  partitions: {layout: single}\n  cues: {samples_per_pixel: 4, max_depth: 2}\n"
         << "  model: {texture_resolution_px: 64, channels_per_basis: 2, ngf: 8, n_blocks: 1, mask_ngf: 4, "
            "mask_n_blocks: 1}\n"
         << "  train: {steps: " << relight_train_steps << ", crop_px: 64, max_validation_frames: 1}\n"
         << "  augment: {maps: 6, map_width_px: 64, views: 2, maps_per_view: 1, directions: 4, "
            "samples_per_pixel: 1, map_samples_per_pixel: 2, steps: 10}\n"
         << "  render: {frames: 2, samples_per_pixel: 2}\n"
         << "  eval: {samples_per_pixel: 2}\n";
    const fs::path path = *dir_ / "pipeline.yaml";
    std::ofstream(path) << yaml.str();
    return path;
  }

  static int Run(const fs::path& yaml, pipeline::RunOptions options, std::string* out) {
    options.workspace = (*dir_ / "ws").string();
    std::ostringstream text;
    const int code = pipeline::RunPipeline(pipeline::PipelineConfig::Load(yaml.string()), options, text);
    *out = text.str();
    return code;
  }

  // Runs the pipeline up to reconstruct; the exit code, its output in `out`.
  static int RunToReconstruct(const fs::path& yaml, std::string* out) {
    pipeline::RunOptions to_reconstruct;
    to_reconstruct.to = {"reconstruct"};
    return Run(yaml, to_reconstruct, out);
  }

  static fs::path* dir_;
  static fs::path* synth_;
};

fs::path* PipelineTinyTest::dir_ = nullptr;
fs::path* PipelineTinyTest::synth_ = nullptr;

TEST_F(PipelineTinyTest, RealStagesChainedByTheOrchestrator) {
  const fs::path yaml = WritePipeline("20");
  const fs::path ws = *dir_ / "ws";
  std::string out;
  ASSERT_EQ(RunToReconstruct(yaml, &out), 0) << out;

  // What the next stages read.
  const CamerasFile cameras = ReadCamerasFile((ws / "calib" / "cameras.json").string());
  // tiny: 30 phone V frames; board-only calibration poses those that see
  // enough of the board (18 when measured).
  EXPECT_GE(cameras.FramesOf("view").size(), 15u);
  EXPECT_TRUE(fs::exists(ws / "calib" / "lights.json"));
  EXPECT_TRUE(fs::exists(ws / "reconstruct" / "proxy.json"));
  EXPECT_TRUE(fs::exists(ws / "reconstruct" / "proxy.obj"));
  const json lock = ReadJsonFile((ws / "relit.lock.json").string(), "lock", 1);
  for (const char* step : {"capture", "calib", "reconstruct"}) {
    EXPECT_EQ(lock["steps"][step]["status"], "done") << step;
  }
  EXPECT_FALSE(lock["steps"].contains("cues"));

  ASSERT_EQ(RunToReconstruct(yaml, &out), 0) << out;
  EXPECT_NE(out.find("everything is up to date (3 steps)"), std::string::npos) << out;

  if (!*kRelight || !*kReport) {
    GTEST_SKIP() << "relit-skip: relit-relight or relit-report is not built: relight and report not checked";
  }
  ASSERT_EQ(Run(yaml, {}, &out), 0) << out;
  const json plan = ReadJsonFile((ws / "relight/plan/plan.json").string(), "relight_plan", 1);
  ASSERT_EQ(plan["partitions"].size(), 1u);  // layout single
  EXPECT_TRUE(fs::exists(ws / "relight/partitions/00/train.json"));
  EXPECT_TRUE(fs::exists(ws / "relight/augment/00/train.json"));
  EXPECT_TRUE(fs::exists(ws / "relight/eval/eval.json"));
  EXPECT_TRUE(fs::exists(ws / "relight/render/render.json"));
  EXPECT_TRUE(fs::exists(ws / "report/index.html"));
  EXPECT_TRUE(fs::exists(ws / "relight/export/manifest.json"));  // run.export: auto
  ASSERT_EQ(Run(yaml, {}, &out), 0) << out;
  EXPECT_NE(out.find("everything is up to date"), std::string::npos) << out;

  // More training steps: training and what follows rerun, nothing before.
  const json before = ReadJsonFile((ws / "relit.lock.json").string(), "lock", 1);
  WritePipeline("30");
  ASSERT_EQ(Run(yaml, {}, &out), 0) << out;
  const json after = ReadJsonFile((ws / "relit.lock.json").string(), "lock", 1);
  for (const char* step : {"capture", "calib", "reconstruct", "cues", "plan"}) {
    EXPECT_EQ(after["steps"][step]["finished_utc"], before["steps"][step]["finished_utc"]) << step;
  }
  for (const char* step : {"train-00", "augment-00", "render", "eval", "report"}) {
    EXPECT_NE(after["steps"][step]["finished_utc"], before["steps"][step]["finished_utc"]) << step;
  }
}

// Rung (o)'s mesh: a sphere whose UV seam repeats positions (as an OBJ's
// seams do) moves out by the offset everywhere, and the seam stays closed.
TEST(LadderOffsetMesh, MovesAlongNormalsWithoutTearingTheSeam) {
  const int segments = 64, rings = 32;
  render::TriangleMesh sphere = render::MakeSphere(Eigen::Vector3f(0.01f, -0.02f, 0.06f), 0.05f, segments, rings);
  for (int r = 0; r <= rings; ++r) {  // the seam's copies exactly equal, as in an OBJ
    sphere.positions[r * (segments + 1) + segments] = sphere.positions[r * (segments + 1)];
  }
  const render::TriangleMesh moved = bench::OffsetAlongNormals(sphere, 0.001);
  ASSERT_EQ(moved.positions.size(), sphere.positions.size());
  EXPECT_TRUE(moved.normals.empty());
  for (size_t i = 0; i < moved.positions.size(); ++i) {
    EXPECT_NEAR((moved.positions[i] - Eigen::Vector3f(0.01f, -0.02f, 0.06f)).norm(), 0.051, 2e-5) << i;
  }
  for (int r = 0; r <= rings; ++r) {
    const int first = r * (segments + 1);
    EXPECT_EQ((moved.positions[first + segments] - moved.positions[first]).norm(), 0.0f) << "ring " << r;
  }
  const render::TriangleMesh shrunk = bench::OffsetAlongNormals(sphere, -0.002);
  EXPECT_NEAR((shrunk.positions[5 * (segments + 1) + 7] - Eigen::Vector3f(0.01f, -0.02f, 0.06f)).norm(), 0.048,
              2e-5);
}

// The error-budget ladder's rung (a) (bench/relight_ladder.h) on the tiny
// capture: calib's output with the truth put in must match truth.json, its
// true mattes must cover the true mesh seen through the rung's own cameras,
// and the workspace it was made from must be left as it was.
TEST_F(PipelineTinyTest, LadderRungTakesCamerasFlashAndMattesFromTheTruth) {
#ifndef RELIT_HAVE_RELIGHT_LADDER
  GTEST_SKIP() << "relit-skip: the benchmarks are not built (RELIT_BUILD_BENCH=OFF)";
#else
  const fs::path yaml = WritePipeline("20");
  const fs::path ws = *dir_ / "ws";
  std::string out;
  ASSERT_EQ(RunToReconstruct(yaml, &out), 0) << out;
  const json truth = ReadJsonFile((*synth_ / "truth.json").string(), synth::kTruthKind, synth::kTruthVersion);
  const std::string cameras_before = ReadJsonFile((ws / "calib" / "cameras.json").string(), "cameras", 1).dump();
  const CalibratedFrame source_frame = *ReadCamerasFile((ws / "calib" / "cameras.json").string()).FramesOf("view")[0];
  const Image image_before = ReadImage((ws / source_frame.image_linear).string());

  const fs::path rung = *dir_ / "rung-a";
  bench::LinkTree(ws / "capture", rung / "capture");
  bench::LinkTree(ws / "calib", rung / "calib");
  bench::LinkTree(ws / "reconstruct", rung / "reconstruct");
  bench::WriteTruthCalib(ws, truth, rung);
  const calib::CalibAccuracy accuracy = calib::MeasureCalibAccuracy(rung.string(), truth);
  ASSERT_GT(accuracy.devices.at("view").frames, 0);
  EXPECT_LT(accuracy.devices.at("view").position_median_mm, 1e-6);
  EXPECT_LT(accuracy.devices.at("view").rotation_median_deg, 1e-6);
  EXPECT_NEAR(accuracy.devices.at("view").focal_error, 0, 1e-9);
  EXPECT_LT(accuracy.flash_median_mm, 1e-6);
  const ProxyFile proxy = ReadProxyFile((rung / "reconstruct" / "proxy.json").string());
  ASSERT_EQ(bench::WriteTruthMattes(rung, *synth_, truth), static_cast<int>(proxy.mattes.size()));

  // Every vertex of the true mesh that a true camera sees inside the image
  // lands on the true matte (3x3 neighbourhood: vertices on the silhouette).
  const render::TriangleMesh mesh =
      render::LoadMesh((*synth_ / truth["objects"][0]["mesh"].get<std::string>()).string());
  const CamerasFile cameras = ReadCamerasFile((rung / "calib" / "cameras.json").string());
  int inside = 0, covered = 0;
  for (const ViewMatte& m : proxy.mattes) {
    const Image matte = ReadImage((rung / m.matte).string());
    const Camera camera = cameras.ViewCamera(*cameras.Find(m.view_frame));
    for (size_t v = 0; v < mesh.positions.size(); v += 7) {
      Eigen::Vector2d px;
      if (!camera.Project(mesh.positions[v].cast<double>(), &px)) continue;
      const int x = static_cast<int>(std::lround(px.x())), y = static_cast<int>(std::lround(px.y()));
      if (x < 1 || y < 1 || x >= matte.width() - 1 || y >= matte.height() - 1) continue;
      float best = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) best = std::max(best, matte.at(x + dx, y + dy, 0));
      }
      ++inside;
      covered += best >= 0.5f;
    }
  }
  ASSERT_GT(inside, 100);
  EXPECT_GE(covered, 0.99 * inside) << covered << " of " << inside << " projected vertices on the true matte";

  // Reconstruct on the true mesh as the ladder runs it for rungs a, b and o:
  // the pipeline's options (here with a normal map, which the workspace's
  // proxy has) but no photometric normal map over the true normals.
  ASSERT_FALSE(proxy.normal_map.empty()) << "the premise: the pipeline's reconstruct estimates a normal map";
  const fs::path mesh_rung = *dir_ / "rung-a-mesh";
  bench::LinkTree(ws / "capture", mesh_rung / "capture");
  bench::LinkTree(ws / "calib", mesh_rung / "calib");
  bench::WriteTruthCalib(ws, truth, mesh_rung);
  const fs::path true_mesh_yaml = *dir_ / "reconstruct_true_mesh.yaml";
  std::ofstream(true_mesh_yaml) << pipeline::YamlText(bench::TrueMeshReconstructOptions(
      pipeline::PipelineConfig::Load(yaml.string()).reconstruct));
  const CommandResult reconstructed = RunCommand(
      ShellQuote(RELIT_RECONSTRUCT_EXE) + " --workspace " + ShellQuote(mesh_rung.string()) + " --config " +
      ShellQuote(true_mesh_yaml.string()) + " --mesh " +
      ShellQuote((*synth_ / truth["objects"][0]["mesh"].get<std::string>()).string()) + " --log-level warn");
  ASSERT_TRUE(reconstructed.ok()) << reconstructed.ErrTail();
  const ProxyFile true_mesh_proxy = ReadProxyFile((mesh_rung / "reconstruct" / "proxy.json").string());
  EXPECT_TRUE(true_mesh_proxy.normal_map.empty()) << true_mesh_proxy.normal_map;
  EXPECT_EQ(true_mesh_proxy.mattes.size(), proxy.mattes.size());

  // The source workspace is untouched (its files were hard-linked, the rung's replaced).
  EXPECT_EQ(ReadJsonFile((ws / "calib" / "cameras.json").string(), "cameras", 1).dump(), cameras_before);
  EXPECT_EQ(ReadImage((ws / source_frame.image_linear).string()).data(), image_before.data());
  EXPECT_NE(ReadImage((rung / source_frame.image_linear).string()).data(), image_before.data());
#endif
}

}  // namespace
}  // namespace relit
