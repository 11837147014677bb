// pipeline.yaml parsing: errors name file, line and key (also inside the
// stage sections, read with the stages' own readers); the template and the
// repository's demo pipeline.yaml parse; per-step configs and parameters.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "pipeline/config.h"
#include "pipeline/steps.h"
#include "pipeline/test_support.h"

namespace relit::pipeline {
namespace {

using testing::TempDir;

const char* kMinimal = "inputs: {view: v.mp4, light: l.mp4}\n";

std::string ErrorOf(const std::string& yaml) {
  try {
    PipelineConfig::FromString(yaml, "/cap/pipeline.yaml", "/cap");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Reading kMinimal + `sections` fails with a message holding every part.
void ExpectErrorHolds(const std::string& sections, const std::vector<std::string>& parts) {
  SCOPED_TRACE(sections);
  const std::string e = ErrorOf(std::string(kMinimal) + sections);
  for (const std::string& part : parts) EXPECT_NE(e.find(part), std::string::npos) << "'" << part << "' not in: " << e;
}

TEST(PipelineConfigTest, UnknownTopLevelKeyNamesFileLineAndSuggestion) {
  ExpectErrorHolds("board: {}\ncalibb: {}\n", {"/cap/pipeline.yaml:3", "unknown key 'calibb'", "did you mean 'calib'"});
}

TEST(PipelineConfigTest, UnknownKeyInsideAStageSectionIsFoundBeforeRunning) {
  ExpectErrorHolds("calib:\n  detect:\n    min_corner: 8\n",
                   {"pipeline.yaml:4", "'calib.detect.min_corner'", "min_corners" /* the suggestion */});
}

TEST(PipelineConfigTest, WrongTypesNameLineAndKey) {
  ExpectErrorHolds("run:\n  jobs: many\n", {"pipeline.yaml:3", "'run.jobs'", "integer"});
  ExpectErrorHolds("capture:\n  view_select: {target_frames: lots}\n",
                   {"pipeline.yaml:3", "'capture.view_select.target_frames'"});
  ExpectErrorHolds("reconstruct:\n  atlas:\n    resolution_px: [1, 2]\n",
                   {"pipeline.yaml:4", "'reconstruct.atlas.resolution_px'"});
  ExpectErrorHolds("board: {squares_x: 7.5}\n", {"'board.squares_x'"});
  ExpectErrorHolds("relight: 3\n", {"'relight' must be a mapping"});
}

TEST(PipelineConfigTest, BadValuesAndMissingInputs) {
  EXPECT_NE(ErrorOf("inputs: {light: l.mp4}\n").find("inputs.view is required"), std::string::npos);
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "run: {executor: pbs}\n").find("'pbs' is not one of local, slurm"),
            std::string::npos);
  const std::string kind = ErrorOf(std::string(kMinimal) + "slurm: {steps: [trian]}\n");
  EXPECT_NE(kind.find("key 'slurm.steps': 'trian' is not one of capture, calib"), std::string::npos) << kind;
  EXPECT_NE(kind.find("did you mean 'train'?"), std::string::npos) << kind;
  // The stage's own checks run too (here: capture needs exactly one of
  // target_frames and target_fps).
  const std::string e =
      ErrorOf(std::string(kMinimal) + "capture: {view_select: {target_frames: 10, target_fps: 2}}\n");
  EXPECT_NE(e.find("capture: "), std::string::npos) << e;
  EXPECT_NE(e.find("target_fps"), std::string::npos) << e;
}

TEST(PipelineConfigTest, KeysRelitSetsItselfAreRejected) {
  ExpectErrorHolds("capture:\n  view: other.mp4\n", {"pipeline.yaml:3", "inputs.view"});
  ExpectErrorHolds("calib: {board: {squares_x: 9}}\n", {"top-level board"});
  ExpectErrorHolds("reconstruct: {mesh: a.obj}\n", {"inputs.proxy_mesh"});
}

// A pipeline.yaml written before proxy.photo / proxy.hull became sections
// says which key moved where, with its line.
TEST(PipelineConfigTest, MovedReconstructKeysNameTheirNewKey) {
  std::string e = ErrorOf(std::string(kMinimal) + "reconstruct:\n  proxy:\n    photo_views: 6\n");
  EXPECT_EQ(e, "/cap/pipeline.yaml:4:18 key 'reconstruct.proxy.photo_views': moved to 'reconstruct.proxy.photo.views'");
  e = ErrorOf(std::string(kMinimal) + "reconstruct: {proxy: {method: dense, hull_points: false}}\n");
  EXPECT_NE(e.find("key 'reconstruct.proxy.hull_points': moved to 'reconstruct.proxy.hull.enabled'"), std::string::npos)
      << e;
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "reconstruct: {proxy: {photo: {views: 6}, hull: {enabled: false}}}\n"),
            "(no error)");
}

TEST(PipelineConfigTest, RelightSectionTopLevelKeysAreChecked) {
  const std::string e = ErrorOf(std::string(kMinimal) + "relight:\n  train: {}\n  trian: {}\n");
  EXPECT_NE(e.find("pipeline.yaml:4"), std::string::npos) << e;
  EXPECT_NE(e.find("'relight.trian'"), std::string::npos) << e;
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "relight: {partitions: {layout: single}, train: {steps: 5}}\n"),
            "(no error)");
}

// relit run checks every key of pipeline.yaml before anything runs, also
// below the second level of relight: (relit-relight's readers, no LibTorch),
// and refuses hostile YAML and inputs that cannot be right.
TEST(PipelineConfigTest, WholeFileIsCheckedBeforeAnythingRuns) {
  std::string e = ErrorOf(std::string(kMinimal) + "relight:\n  train: {stesp: 10}\n");
  EXPECT_NE(e.find("pipeline.yaml:3"), std::string::npos) << e;
  EXPECT_NE(e.find("'relight.train.stesp'"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'steps'"), std::string::npos) << e;
  e = ErrorOf(std::string(kMinimal) + "relight:\n  model: {norm: batch}\n");
  EXPECT_NE(e.find("relight"), std::string::npos) << e;
  EXPECT_NE(e.find("norm"), std::string::npos) << e;
  // An alias bomb inside a stage section.
  std::string bomb = std::string(kMinimal) + "relight:\n  cues:\n    a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]\n";
  for (char level = 'b'; level <= 'i'; ++level) {
    bomb += "    " + std::string(1, level) + ": &" + std::string(1, level) + " [";
    for (int i = 0; i < 9; ++i) bomb += std::string(i ? ", *" : "*") + static_cast<char>(level - 1);
    bomb += "]\n";
  }
  e = ErrorOf(bomb);
  EXPECT_NE(e.find("pipeline.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("aliases"), std::string::npos) << e;
  // The same video for both phones.
  e = ErrorOf("inputs: {view: v.mp4, light: ./v.mp4}\n");
  EXPECT_NE(e.find("same file"), std::string::npos) << e;
  TempDir dir;
  e = ErrorOf("inputs: {view: " + dir.path().string() + ", light: l.mp4}\n");
  EXPECT_NE(e.find("is a folder"), std::string::npos) << e;
}

TEST(PipelineConfigTest, PathsAreRelativeToTheYamlFolder) {
  const PipelineConfig c = PipelineConfig::FromString(
      "inputs: {view: cap/v.mp4, light: /abs/l.mp4, proxy_mesh: ../m.obj}\n"
      "tools: {relight: bin/relit-relight}\n",
      "/data/x/pipeline.yaml", "/data/x");
  EXPECT_EQ(c.view, "/data/x/cap/v.mp4");
  EXPECT_EQ(c.light, "/abs/l.mp4");
  EXPECT_EQ(c.proxy_mesh, "/data/m.obj");
  EXPECT_EQ(c.geometry, "");
  EXPECT_EQ(c.tools.at("relight"), "/data/x/bin/relit-relight");
}

TEST(PipelineConfigTest, SlurmResourcesPerKindStartFromTheDefaults) {
  const PipelineConfig c = PipelineConfig::FromString(
      std::string(kMinimal) +
          "run: {executor: slurm}\n"
          "slurm:\n  resources: {partition: cpu, cpus: 4, memory: 6G}\n  train: {gpus: 1, time: '1:00:00'}\n",
      "p.yaml", "/");
  EXPECT_EQ(c.executor, "slurm");
  EXPECT_EQ(c.slurm.For("cues").cpus, 4);
  EXPECT_EQ(c.slurm.For("train").partition, "cpu");
  EXPECT_EQ(c.slurm.For("train").memory, "6G");
  EXPECT_EQ(c.slurm.For("train").gpus, 1);
  EXPECT_EQ(c.slurm.For("train").time, "1:00:00");
  EXPECT_EQ(c.slurm.For("cues").gpus, 0);
}

TEST(PipelineConfigTest, TemplateAndDemoPipelineParse) {
  TempDir dir;
  testing::WriteText(dir.path() / "pipeline.yaml", PipelineTemplate());
  const PipelineConfig t = PipelineConfig::Load((dir.path() / "pipeline.yaml").string());
  EXPECT_EQ(t.view, (dir.path() / "view.mp4").string());
  EXPECT_EQ(t.jobs, 1);

  const PipelineConfig demo = PipelineConfig::Load(std::string(RELIT_SOURCE_DIR) + "/pipeline.yaml");
  EXPECT_EQ(demo.view, std::string(RELIT_SOURCE_DIR) + "/demo/capture/view.mp4");
  EXPECT_EQ(demo.board["dictionary"].as<std::string>(), "DICT_4X4_50");  // the synth demo board
}

TEST(PipelineConfigTest, StepsGetTheirSectionAsConfigAndHashOnlyWhatTheyRead) {
  const PipelineConfig c = PipelineConfig::FromString(
      "inputs: {view: v.mp4, light: l.mp4, board_view_images: bv}\n"
      "board: {squares_x: 9, dictionary: DICT_4X4_50}\n"
      "calib: {detect: {min_corners: 8}, log_level: debug}\n"
      "relight: {cues: {samples_per_pixel: 4}, train: {steps: 10}, partitions: {layout: single}}\n",
      "/c/pipeline.yaml", "/c");
  StepGraph graph(c, "/w", false);
  graph.ExpandPartitions({0});
  const Step* calib = graph.Find("calib");
  ASSERT_NE(calib, nullptr);
  // The board and the board clip are injected into calib's config file.
  EXPECT_NE(calib->config_yaml.find("squares_x: 9"), std::string::npos) << calib->config_yaml;
  EXPECT_NE(calib->config_yaml.find("view_board_images: /c/bv"), std::string::npos);
  EXPECT_EQ(calib->params["board"]["squares_x"], "9");
  EXPECT_FALSE(calib->params["calib"].contains("log_level"));  // printing is not a parameter
  ASSERT_EQ(calib->inputs.size(), 1u);
  EXPECT_EQ(calib->inputs[0].role, "inputs.board_view_images");

  const Step* cues = graph.Find("cues");
  const Step* train = graph.Find("train-00");
  ASSERT_TRUE(cues && train);
  EXPECT_EQ(cues->params.size(), 1u);
  EXPECT_TRUE(cues->params.contains("relight.cues"));
  EXPECT_FALSE(train->params.contains("relight.cues"));
  EXPECT_EQ(train->params["relight.train"]["steps"], "10");
  // Every relight sub-step gets the whole relight: section (the contract).
  EXPECT_EQ(cues->config_yaml, train->config_yaml);
  EXPECT_EQ(train->args[0], "train");
  EXPECT_EQ(train->output, "relight/partitions/00");
  const Step* render = graph.Find("render");
  EXPECT_NE(std::find(render->deps.begin(), render->deps.end(), "train-00"), render->deps.end());
}

// Augment steps follow every train step (their targets blend all the
// point-light partitions); eval exists with a ground truth and waits for them.
TEST(PipelineConfigTest, AugmentAndEvalStepsSitBetweenTrainingAndWhatReadsTheModels) {
  const PipelineConfig c = PipelineConfig::FromString(
      "inputs: {view: v.mp4, light: l.mp4, truth: cap/truth.json}\n"
      "relight: {augment: {steps: 5}, train: {steps: 10}}\n",
      "/c/pipeline.yaml", "/c");
  StepGraph graph(c, "/w", true, true);
  graph.ExpandPartitions({0, 1});
  const Step* augment = graph.Find("augment-01");
  ASSERT_NE(augment, nullptr);
  for (const char* dep : {"train-00", "train-01", "plan", "cues"}) {
    EXPECT_NE(std::find(augment->deps.begin(), augment->deps.end(), dep), augment->deps.end()) << dep;
  }
  EXPECT_EQ(augment->params["relight.augment"]["steps"], "5");
  EXPECT_FALSE(augment->params.contains("relight.model"));
  EXPECT_EQ(augment->output, "relight/augment/01");
  for (const char* reader : {"render", "export", "eval", "report"}) {
    const Step* s = graph.Find(reader);
    ASSERT_NE(s, nullptr) << reader;
    EXPECT_NE(std::find(s->deps.begin(), s->deps.end(), "augment-00"), s->deps.end()) << reader;
  }
  const Step* eval = graph.Find("eval");
  ASSERT_EQ(eval->inputs.size(), 1u);
  EXPECT_EQ(eval->inputs[0].path, "/c/cap/truth.json");
  EXPECT_NE(std::find(eval->args.begin(), eval->args.end(), "--truth"), eval->args.end());

  StepGraph without(c, "/w", true, false);
  without.ExpandPartitions({0});
  EXPECT_EQ(without.Find("augment-00"), nullptr);
}

}  // namespace
}  // namespace relit::pipeline
