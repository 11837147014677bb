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

#include "core/json_file.h"
#include "core/workspace.h"
#include "pipeline/runner.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

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

  static fs::path* dir_;
  static fs::path* synth_;
};

fs::path* PipelineTinyTest::dir_ = nullptr;
fs::path* PipelineTinyTest::synth_ = nullptr;

TEST_F(PipelineTinyTest, RealStagesChainedByTheOrchestrator) {
  const fs::path yaml = WritePipeline("20");
  const fs::path ws = *dir_ / "ws";
  std::string out;
  pipeline::RunOptions to_reconstruct;
  to_reconstruct.to = {"reconstruct"};
  ASSERT_EQ(Run(yaml, to_reconstruct, &out), 0) << out;

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

  ASSERT_EQ(Run(yaml, to_reconstruct, &out), 0) << out;
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

}  // namespace
}  // namespace relit
