// The baselines of docs/relight.md ("Baselines") through the command line on
// a tiny ground-truth workspace: the 1-basis ablation (cues.bases: [lambert])
// and the spherical-harmonics DNR baseline (cues.input: sh) each go through
// cues -> plan -> train -> render -> export -> eval, their files carry the
// format, a mismatched config is a clear error, and `compare` tabulates both.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"
#include "core/options.h"
#include "core/run_record.h"
#include "relight/asset.h"
#include "relight/compare.h"
#include "relight/augment.h"
#include "relight/relight_options.h"
#include "relight/train_stage.h"
#include "relight/test_stages.h"
#include "relight/test_workspace.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kWidth = 160, kHeight = 120;

using testing::RunCli;

class BaselinesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = (fs::temp_directory_path() / ("relit_baselines_" + std::to_string(::getpid()))).string();
    const auto start = std::chrono::steady_clock::now();
    testing::TestWorkspaceOptions workspace;
    workspace.frames = 12;
    workspace.samples_per_pixel = 8;
    testing::MakeTestWorkspace(dir_ + "/base", workspace);
    truth_ = testing::WriteTestTruth(dir_ + "/capture", true, kWidth, kHeight);
    std::printf("workspace + truth: %.1f s\n", SecondsSince(start));
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  // A copy of the base workspace and a config with `cues_extra` in `cues:`.
  static std::pair<std::string, std::string> Variant(const std::string& name, const std::string& cues_extra) {
    const std::string ws = dir_ + "/" + name;
    fs::remove_all(ws);
    fs::copy(dir_ + "/base", ws, fs::copy_options::recursive);
    const std::string config = dir_ + "/" + name + ".yaml";
    std::ofstream(config) << "cues: {samples_per_pixel: 4" << cues_extra << "}\n"
                          << "dataset: {holdout_every: 4}\npartitions: {layout: single}\n"
                          << "model: {variant: dnl, texture_resolution_px: 64, channels_per_basis: 4, ngf: 8, n_blocks: 2, "
                             "mask_ngf: 4, mask_n_blocks: 1}\n"
                          << "train: {steps: 100, checkpoint_every: 100, validate_every: 0, crop_px: 64, "
                             "learning_rate: 2e-3, seed: 5}\n"
                          << "render: {samples_per_pixel: 4}\neval: {samples_per_pixel: 4}\n";
    return {ws, config};
  }

  // cues, plan, train, render --views, export, eval; returns eval.json.
  static json RunAll(const std::string& ws, const std::string& config) {
    const auto start = std::chrono::steady_clock::now();
    for (const char* step : {"cues", "plan"}) {
      EXPECT_EQ(RunCli({"relit-relight", step, "--workspace", ws, "--config", config, "--log-level", "warn"}), 0);
    }
    EXPECT_EQ(RunCli({"relit-relight", "train", "--workspace", ws, "--config", config, "--partition", "0",
                      "--log-level", "warn"}),
              0);
    const AssetDescription asset = DescribeWorkspace(ws);
    const Camera camera(asset.camera, LookAt(asset.object_centre_m + Eigen::Vector3d(0.25, -0.2, 0.2),
                                             asset.object_centre_m, Eigen::Vector3d::UnitZ()));
    const json views = {{"views",
                         {{{"name", "key"}, {"cam_from_world", ToJson(camera.cam_from_world())},
                           {"light", {{"type", "point"}, {"position_m", {0.3, -0.1, 0.4}}, {"intensity", 1.0}}}}}}};
    std::ofstream(ws + "/views.json") << views.dump(2);
    EXPECT_EQ(RunCli({"relit-relight", "render", "--workspace", ws, "--config", config, "--views", ws + "/views.json",
                      "--out", ws + "/views", "--log-level", "warn"}),
              0);
    EXPECT_EQ(RunCli({"relit-relight", "export", "--workspace", ws, "--config", config, "--no-interop",
                      "--log-level", "warn"}),
              0);
    EXPECT_EQ(RunCli({"relit-relight", "eval", "--workspace", ws, "--config", config, "--truth", truth_,
                      "--log-level", "warn"}),
              0);
    std::printf("%s: cues .. eval %.1f s\n", fs::path(ws).filename().c_str(), SecondsSince(start));
    const Image key = ReadImage(ws + "/views/key.exr");
    double alpha = 0;
    for (int y = 0; y < key.height(); ++y) {
      for (int x = 0; x < key.width(); ++x) alpha += key.at(x, y, 3);
    }
    EXPECT_GT(alpha, 100.0);
    return ReadJsonFile(ws + "/relight/eval/eval.json", "eval", 1);
  }

  static void ExpectScored(const json& eval, const std::string& variant) {
    EXPECT_EQ(eval["model_variant"], variant);
    EXPECT_EQ(eval["methods"], json({"model"}));
    EXPECT_TRUE(eval["skipped_reasons"].contains("cues_only")) << eval["skipped_reasons"].dump();
    ASSERT_EQ(eval["images"].size(), 15u);  // (2 extrapolation + 1 interpolation) views x 5 lights, env maps included
    for (const json& row : eval["summary"]) {
      for (const char* key : {"psnr_db", "mae", "ssim", "alpha_mae"}) {
        ASSERT_TRUE(row[key].is_number()) << row.dump();
        EXPECT_TRUE(std::isfinite(row[key].get<double>())) << row.dump();
      }
      std::printf("%-12s %-12s PSNR %6.2f dB  MAE %.4f  SSIM %.3f  alpha MAE %.4f\n", variant.c_str(),
                  row["light_type"].get<std::string>().c_str(), row["psnr_db"].get<double>(),
                  row["mae"].get<double>(), row["ssim"].get<double>(), row["alpha_mae"].get<double>());
      // 100 steps from a random texture: the mask has found the object.
      EXPECT_LT(row["alpha_mae"].get<double>(), 0.05) << row.dump();  // measured 0.008-0.009
    }
  }

  static std::string dir_, truth_;
};
std::string BaselinesTest::dir_, BaselinesTest::truth_;

TEST_F(BaselinesTest, OneBasisAblationFlowsThroughEveryStep) {
  const auto [ws, config] = Variant("one_basis", ", bases: [lambert]");
  const json eval = RunAll(ws, config);
  // Cue frames: 3 Lambert channels + the 7 geometry channels.
  const json cues = ReadJsonFile(ws + "/relight/cues/cues.json", "cues", 1);
  EXPECT_EQ(cues["bases"], json({"lambert"}));
  const Image frame = ReadImage(ws + "/" + cues["frames"][0]["file"].get<std::string>());
  EXPECT_EQ(frame.channels(), 10);
  EXPECT_GE(frame.ChannelIndex("cue0.R"), 0);
  EXPECT_LT(frame.ChannelIndex("cue1.R"), 0);
  const json checkpoint = ReadJsonFile(ws + "/relight/partitions/00/checkpoint/checkpoint.json", "checkpoint", 1);
  EXPECT_EQ(checkpoint["model_options"]["bases"], json({"lambert"}));
  const json train = ReadJsonFile(ws + "/relight/partitions/00/train.json", "run", 1);
  EXPECT_GT(train["process_cpu_s"].get<double>(), 0.0);
  // The asset: 1 x C texture channels, the basis in the manifest.
  EXPECT_EQ(ReadImage(ws + "/relight/export/textures/00.exr").channels(), 4);
  const json manifest = ReadJsonFile(ws + "/relight/export/manifest.json", "asset", 1);
  EXPECT_EQ(manifest["cues"]["basis"], json({"lambert"}));
  ExpectScored(eval, "dnl_1_basis");
  // Against the path-traced truth under point lights: measured 17.3 dB.
  for (const json& row : eval["summary"]) {
    if (row["light_type"] == "point") {
      EXPECT_GT(row["psnr_db"].get<double>(), 14.0);
    }
  }

  // The default config on this workspace: clear errors, nothing garbled.
  const std::string default_config = dir_ + "/default.yaml";
  std::ofstream(default_config) << "partitions: {layout: single}\n";
  try {
    RunCli({"relit-relight", "eval", "--workspace", ws, "--config", default_config, "--truth", truth_, "--out",
            ws + "/eval_default", "--log-level", "error"});
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("was trained on radiance cues, 1 basis (lambert)"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(ws + "/eval_default"));
  try {
    RunCli({"relit-relight", "train", "--workspace", ws, "--config", default_config, "--partition", "0",
            "--log-level", "error"});
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rerun `relit-relight cues`"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::exists(ws + "/relight/partitions/00/train.json"));  // the refused run removed nothing
}

TEST_F(BaselinesTest, ShBaselineFlowsThroughEveryStepAndCompares) {
  const auto [ws, config] = Variant("sh", ", input: sh, support_plane: false");
  const json eval = RunAll(ws, config);
  const json cues = ReadJsonFile(ws + "/relight/cues/cues.json", "cues", 1);
  EXPECT_EQ(cues["input"], "sh");
  const Image frame = ReadImage(ws + "/" + cues["frames"][0]["file"].get<std::string>());
  EXPECT_EQ(frame.channels(), 21 + 7);
  EXPECT_GE(frame.ChannelIndex("shl8"), 0);
  EXPECT_GE(frame.ChannelIndex("level.G"), 0);
  EXPECT_EQ(ReadImage(ws + "/relight/export/textures/00.exr").channels(), 21 + 4);
  const json manifest = ReadJsonFile(ws + "/relight/export/manifest.json", "asset", 1);
  EXPECT_EQ(manifest["cues"]["input"], "sh");
  ExpectScored(eval, "sh_dnr");

  // compare: one table for the two workspaces (the 1-basis one when its test ran first).
  std::vector<CompareInput> inputs = {{ws + "/relight/eval", "sh"}};
  if (fs::exists(dir_ + "/one_basis/relight/eval/eval.json")) inputs.push_back({dir_ + "/one_basis/relight/eval", ""});
  const std::string table = CompareEvaluations(inputs);
  std::printf("%s", table.c_str());
  EXPECT_NE(table.find("| sh: sh_dnr | 100 | "), std::string::npos) << table;
  {
    // An augment folder the eval did not read (stale) is not the model's training.
    const fs::path stale = fs::path(ws) / "relight" / "augment" / "00";
    ASSERT_FALSE(fs::exists(stale.parent_path()));  // this workspace was not augmented
    fs::create_directories(stale);
    std::ofstream(stale / "train.json") << nlohmann::json({{"schema", "relit.run/1"}, {"steps", 5000},
                                                           {"process_cpu_s", 36000.0}, {"total_s", 36000.0}}).dump();
    const std::string with_stale = CompareEvaluations({{ws + "/relight/eval", "sh"}});
    fs::remove_all(stale.parent_path());
    EXPECT_NE(with_stale.find("| sh: sh_dnr | 100 | "), std::string::npos) << with_stale;
  }
  EXPECT_NE(table.find("CPU-h"), std::string::npos) << table;
  EXPECT_NE(table.find("| environment |"), std::string::npos) << table;
  if (inputs.size() > 1) {
    EXPECT_NE(table.find("eval: dnl_1_basis"), std::string::npos) << table;
  }
  EXPECT_THROW(CompareEvaluations({{dir_ + "/nowhere", ""}}), Error);
  // Evaluations clipped at different white levels are not comparable.
  EXPECT_NE(table.find("clipped at 1 (eval.clip_radiance)"), std::string::npos) << table;
  const std::string unclipped = dir_ + "/unclipped_eval";
  fs::create_directories(unclipped);
  json other = ReadJsonFile(ws + "/relight/eval/eval.json", "eval", 1);
  other["clip_radiance"] = 0;
  WriteJsonFile(unclipped + "/eval.json", "eval", 1, other);
  EXPECT_EQ(CompareEvaluations({{unclipped, ""}}).find("clipped at"), std::string::npos);
  EXPECT_THROW(CompareEvaluations({{ws + "/relight/eval", "sh"}, {unclipped, ""}}), Error);
}

TEST(BaselineOptions, UnknownInputsAndBasesAreErrors) {
  for (const char* bad : {"cues: {input: dnr}\n", "cues: {bases: [lambert, ggx_0.5]}\n", "cues: {bases: []}\n",
                          "cues: {base: [lambert]}\n"}) {
    OptionsReader reader = OptionsReader::FromString(bad);
    EXPECT_THROW(ReadRelightSection(reader), Error) << bad;
  }
  // The residual model regresses the 5 default cues: other cues need dnl.
  OptionsReader residual = OptionsReader::FromString("cues: {bases: [ggx_0.13, lambert]}\n");
  EXPECT_THROW(ReadRelightSection(residual), Error);
  OptionsReader reader = OptionsReader::FromString("cues: {bases: [ggx_0.13, lambert]}\nmodel: {variant: dnl}\n");
  const RelightOptions options = ReadRelightSection(reader);
  EXPECT_EQ(options.cues.Format().light_channels(), 6);
  EXPECT_EQ(OptionsToJson(options.cues)["bases"], json({"ggx_0.13", "lambert"}));
  EXPECT_FALSE(OptionsToJson(RelightOptions().cues).contains("bases"));  // defaults: records as before
}

}  // namespace
}  // namespace relit::relight
