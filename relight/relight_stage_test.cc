// The relight stage on a small ground-truth workspace: cues -> plan ->
// train -> render, the learning check against the cues-only baseline, exact
// resume, and errors for missing inputs.
#include <chrono>
#include <functional>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/image.h"
#include "core/median.h"
#include "core/run_record.h"
#include "core/test_dir.h"
#include "core/json_file.h"
#include "relight/asset.h"
#include "relight/augment.h"
#include "relight/checkpoint.h"
#include "relight/cue_frames.h"
#include "relight/cue_stage.h"
#include "relight/cues_baseline.h"
#include "relight/cue_texture_fit.h"
#include "relight/dataset.h"
#include "relight/metrics.h"
#include "relight/plan.h"
#include "relight/render_stage.h"
#include "relight/test_stages.h"
#include "relight/test_workspace.h"
#include "relight/train_stage.h"
#include "relight/warm_start.h"
#include "tools/synth/scene.h"
#include "tools/synth/synth_options.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;

using testing::SmallModel;

TrainStageOptions SmallTraining(int steps) {
  TrainStageOptions t;
  t.steps = steps;
  t.checkpoint_every = 100;
  t.validate_every = 0;
  t.log_every = 10;
  t.optimizer.crop_px = 96;  // Adam rates: the defaults (networks 2e-4 as DNL, texture 2e-2)
  t.optimizer.seed = 5;
  t.optimizer.threads = 2;
  return t;
}

// Pooled metrics of `predict(cue frame)` against the plan's frames `indices`.
// `binary_matte`: the matte thresholded at 0.5, so that the reference is
// the captured pixels themselves there (ScoreModelOnCapturedPixels).
ImageMetrics ScoreFrames(const std::string& dir, const Plan& plan, const std::vector<int>& indices,
                         const std::function<Image(const Image&)>& predict, bool binary_matte = false) {
  std::vector<ImageMetrics> metrics;
  for (int index : indices) {
    const PlanFrame& f = plan.frames[index];
    Image matte = ReadImage(dir + "/" + f.matte);
    if (binary_matte) {
      for (float& a : matte.data()) a = a >= 0.5f ? 1.0f : 0.0f;
    }
    metrics.push_back(
        CompareToReference(predict(ReadCueFrame(dir + "/" + f.cues)), ReadImage(dir + "/" + f.image), matte));
  }
  return PoolMetrics(metrics);
}

ImageMetrics ScoreModel(const std::string& dir, const Plan& plan, const std::vector<int>& indices, DnlModel& model) {
  return ScoreFrames(dir, plan, indices, [&](const Image& cues) { return RenderFrame(model, CueFrameToBatch(cues)); });
}

// The model's renders against the captured pixels themselves where the
// matte is >= 0.5: a silhouette pixel of a frame is already the object's
// share plus the background's, which is what the model trains on, so the
// frame is not multiplied by the matte again (CompareToReference's
// reference for straight truth colours).
ImageMetrics ScoreModelOnCapturedPixels(const std::string& dir, const Plan& plan, const std::vector<int>& indices,
                                        DnlModel& model) {
  return ScoreFrames(
      dir, plan, indices, [&](const Image& cues) { return RenderFrame(model, CueFrameToBatch(cues)); }, true);
}

// The cues-only baseline (per-texel least squares of the 5 cues) fitted on
// the plan's training frames.
CuesOnlyBaseline FitCuesOnly(const std::string& dir, const Plan& plan) {
  CuesOnlyBaseline baseline(SmallModel().texture_resolution_px);
  testing::ForEachTrainFrame(dir, plan, [&](const Image& cues, const Image& image, const Image& matte) {
    baseline.Accumulate(cues, image, matte);
  });
  baseline.Solve();
  return baseline;
}

class RelightStageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = (fs::temp_directory_path() / ("relit_relight_stage_" + std::to_string(::getpid()))).string();
    const auto start = std::chrono::steady_clock::now();
    testing::TestWorkspaceOptions o;
    testing::MakeTestWorkspace(dir_, o);
    std::printf("workspace: %.1f s\n", SecondsSince(start));
    const auto cues_start = std::chrono::steady_clock::now();
    CueStageOptions cues;
    cues.samples_per_pixel = 8;
    RunRecord record("test");
    testing::RunCuesAndSinglePartitionPlan(dir_, cues, record);
    std::printf("cues + plan: %.1f s\n", SecondsSince(cues_start));
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string dir_;
};
std::string RelightStageTest::dir_;

TEST_F(RelightStageTest, CuesAndPlanDescribeEveryFrame) {
  const CuesFile cues = ReadCuesFile(dir_ + "/relight/cues/cues.json");
  EXPECT_EQ(cues.frames.size(), 24u);
  const Image first = ReadCueFrame(dir_ + "/" + cues.frames[0].file);
  EXPECT_EQ(first.channels(), 22);
  EXPECT_EQ(first.width(), 160);
  // The proxy covers part of the frame, with uvs in [0, 1] where it does.
  int covered = 0;
  for (int y = 0; y < first.height(); ++y) {
    for (int x = 0; x < first.width(); ++x) {
      if (first.at(x, y, 21) < 1) continue;
      ++covered;
      EXPECT_GE(first.at(x, y, 15), 0.0f);
      EXPECT_LE(first.at(x, y, 15), 1.0f);
    }
  }
  EXPECT_GT(covered, 500);
  // The table's albedo, measured on the frames against the paper, is the
  // synthetic wood's diffuse part (its glossy lobe adds a little).
  ASSERT_TRUE(cues.support_plane.enabled);
  const Eigen::Vector3d wood(0.22, 0.14, 0.08);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(cues.support_plane.table_albedo[c], wood[c], 0.1 * wood[c]) << c;
  const Plan plan = ReadPlan(dir_ + "/relight/plan/plan.json");
  ASSERT_EQ(plan.partitions.size(), 1u);
  EXPECT_EQ(plan.partitions[0].train_frames.size(), 18u);
  EXPECT_EQ(plan.partitions[0].validation_frames.size(), 6u);
  EXPECT_GT(plan.max_radiance, 0.0);
}

// Learning on real cue frames: after a short training run (300 steps) the
// held-out frames beat the cues-only baseline (per-texel least squares of the
// 5 cues, fitted on the same training frames) by 2 dB, training keeps the
// smooth warm start's quality, and the mask beats the proxy's coverage
// (docs/relight.md, "Learning check").
TEST_F(RelightStageTest, TrainedModelBeatsCuesOnlyBaselineOnHeldOutFrames) {
  const auto start = std::chrono::steady_clock::now();
  RunRecord record("test");
  const TrainStageOptions training = SmallTraining(300);
  // With the mask correction (off by default): this workspace's mattes are
  // the true ones, so the network can learn an alpha better than the offset
  // proxy's coverage. The stage's own mattes are not (docs/relight.md, "Alpha").
  ModelOptions model = SmallModel();
  model.mask_correction = true;
  const TrainStageResult result = RunTrainStage(dir_, 0, model, training, true, record);
  std::printf("training: %lld steps in %.1f s\n", static_cast<long long>(result.steps), SecondsSince(start));
  ASSERT_FALSE(result.skipped);

  const Plan plan = ReadPlan(dir_ + "/relight/plan/plan.json");
  const CuesOnlyBaseline baseline = FitCuesOnly(dir_, plan);
  // The smooth fit the model starts from (train.cue_fit defaults).
  CueTextureFit smooth_fit(SmallModel().texture_resolution_px, training.optimizer.cue_fit);
  testing::ForEachTrainFrame(dir_, plan, [&](const Image& cues, const Image& image, const Image& matte) {
    smooth_fit.AddFrame(cues, image, matte);
  });
  smooth_fit.Solve();
  DnlModel trained = LoadModel(fs::path(dir_) / "relight/partitions/00/checkpoint");
  // The residual model at step 0: its cue regression warm-started on the
  // same training frames, its corrections gated off.
  ModelOptions untrained_options = model;
  untrained_options.max_radiance = plan.max_radiance;
  Trainer untrained(untrained_options, training.optimizer);
  std::vector<Batch> train_frames;
  for (int index : plan.partitions[0].train_frames) train_frames.push_back(LoadPlanFrame(dir_, plan.frames[index]));
  WarmStartCueRegression(untrained.model(), train_frames, training.optimizer.cue_fit);
  const std::vector<int>& held_out = plan.partitions[0].validation_frames;
  const ImageMetrics ours = ScoreModel(dir_, plan, held_out, trained),
                     before = ScoreModel(dir_, plan, held_out, untrained.model()),
                     theirs = ScoreFrames(dir_, plan, held_out, [&](const Image& c) { return baseline.Predict(c); }),
                     smooth = ScoreFrames(dir_, plan, held_out, [&](const Image& c) { return smooth_fit.Predict(c); });
  std::printf("training frames PSNR: trained %.2f dB\n",
              ScoreModel(dir_, plan, plan.partitions[0].train_frames, trained).psnr_db);
  std::printf("held-out PSNR: trained %.2f dB (MAE %.4f, alpha MAE %.4f), step 0 %.2f dB (alpha MAE %.4f), "
              "smooth cue fit %.2f dB, cues-only baseline %.2f dB (MAE %.4f)\n",
              ours.psnr_db, ours.mae, ours.alpha_mae, before.psnr_db, before.alpha_mae, smooth.psnr_db,
              theirs.psnr_db, theirs.mae);
  // Step 0 is the smooth cue fit (same least-squares problem, same
  // texels) with the proxy's coverage as alpha.
  EXPECT_NEAR(before.psnr_db, smooth.psnr_db, 0.1);
  // Measured (2026-11-28): trained 16.53 dB, smooth fit 16.43, cues-only
  // 13.99 (issue 24's +2 dB over cues-only), alpha MAE 0.0041 vs the
  // coverage's 0.0064.
  // Training keeps the fit's quality (the corrections add little here).
  EXPECT_GT(ours.psnr_db, theirs.psnr_db + 2.0);
  EXPECT_GT(ours.psnr_db, before.psnr_db - 0.2);
  EXPECT_LT(ours.mae, theirs.mae);
  EXPECT_LT(ours.alpha_mae, 0.85 * before.alpha_mae);  // better than the proxy's own coverage
  EXPECT_NEAR(result.val_psnr_db, ours.psnr_db, 3.0);  // the stage's own validation agrees (subset of frames)
}

// The learning check with true inputs (issue 24's input ladder, rung a):
// the ground-truth mesh as the proxy, true cameras, flash and mattes,
// targets at 128 spp and cues at 64 spp, so that neither the proxy nor the
// render noise limits the fit. The model must reproduce its training frames
// (>= 28 dB) and beat the cues-only baseline on held-out frames by 2 dB.
// The fixture removes the workspace however the test ends.
class RelightTrueInputs : public test_support::TempDirTest {
 protected:
  RelightTrueInputs() : TempDirTest("relit_relight_true_inputs_") {}
};

TEST_F(RelightTrueInputs, ModelFitsItsTrainingFramesAndBeatsCuesOnlyOnHeldOutFrames) {
  const std::string dir = root_.string();
  testing::TestWorkspaceOptions o;
  o.proxy_offset_m = 0;
  o.samples_per_pixel = 128;
  testing::MakeTestWorkspace(dir, o);
  CueStageOptions cues;
  cues.samples_per_pixel = 64;
  RunRecord record("test");
  testing::RunCuesAndSinglePartitionPlan(dir, cues, record);
  const TrainStageResult result = RunTrainStage(dir, 0, SmallModel(), SmallTraining(300), true, record);
  ASSERT_FALSE(result.skipped);

  const Plan plan = ReadPlan(dir + "/relight/plan/plan.json");
  const CuesOnlyBaseline baseline = FitCuesOnly(dir, plan);
  DnlModel trained = LoadModel(fs::path(dir) / "relight/partitions/00/checkpoint");
  const ImageMetrics fit = ScoreModelOnCapturedPixels(dir, plan, plan.partitions[0].train_frames, trained),
                     ours = ScoreModel(dir, plan, plan.partitions[0].validation_frames, trained),
                     theirs = ScoreFrames(dir, plan, plan.partitions[0].validation_frames,
                                          [&](const Image& c) { return baseline.Predict(c); });
  std::printf("true inputs: training frames %.2f dB, held-out %.2f dB, cues-only %.2f dB\n", fit.psnr_db,
              ours.psnr_db, theirs.psnr_db);
  // Measured (2026-11-26): training frames 29.9 dB, held-out 24.5, cues-only
  // 16.7. With 8-spp cues the same run gives 24.4 / 19.0: cue noise, not
  // the model, is what limits it then. Since the residual model renders
  // premultiplied radiance (2026-11-28), its training frames are scored
  // against the captured pixels (ScoreModelOnCapturedPixels): against
  // frame x matte it read 27.7 dB, charging the silhouette for the matte
  // twice.
  EXPECT_GE(fit.psnr_db, 28.0);
  EXPECT_GT(ours.psnr_db, theirs.psnr_db + 2.0);
}

// Training 40 steps in two runs (20, then continued to 40) logs the same
// losses as one uninterrupted 40-step run.
TEST_F(RelightStageTest, ContinuedTrainingReproducesTheUninterruptedRun) {
  auto losses = [&](const std::string& log) {
    std::vector<double> values;
    std::ifstream in(log);
    std::string line;
    while (std::getline(in, line)) {
      const auto j = nlohmann::json::parse(line);
      if (j.contains("loss")) values.push_back(j["loss"].get<double>());
    }
    return values;
  };
  RunRecord record("test");
  TrainStageOptions options = SmallTraining(40);
  options.checkpoint_every = 20;
  RunTrainStage(dir_, 0, SmallModel(), options, true, record);
  const std::vector<double> straight = losses(dir_ + "/relight/partitions/00/log.jsonl");
  options.steps = 20;
  RunTrainStage(dir_, 0, SmallModel(), options, true, record);
  options.steps = 40;
  const TrainStageResult continued = RunTrainStage(dir_, 0, SmallModel(), options, false, record);
  EXPECT_EQ(continued.resumed_from, 20);
  const std::vector<double> resumed = losses(dir_ + "/relight/partitions/00/log.jsonl");
  ASSERT_EQ(straight.size(), 4u);
  ASSERT_EQ(resumed.size(), 4u);
  for (size_t i = 0; i < straight.size(); ++i) EXPECT_EQ(straight[i], resumed[i]) << "log line " << i;
  // Changed model options: the checkpoint is not reused.
  ModelOptions other = SmallModel();
  other.ngf = 8;
  EXPECT_EQ(RunTrainStage(dir_, 0, other, options, false, record).resumed_from, 0);
  // New cue frames under the same plan (a new proxy): not reused either.
  options.steps = 20;
  RunTrainStage(dir_, 0, SmallModel(), options, true, record);
  const std::string first_cue = dir_ + "/" + ReadCuesFile(dir_ + "/relight/cues/cues.json").frames.front().file;
  std::ofstream(first_cue, std::ios::app) << ' ';
  options.steps = 40;
  EXPECT_EQ(RunTrainStage(dir_, 0, SmallModel(), options, false, record).resumed_from, 0);
}

TEST_F(RelightStageTest, RenderWritesTurntablesFromTheTrainedPartition) {
  RunRecord record("test");
  RunTrainStage(dir_, 0, SmallModel(), SmallTraining(20), true, record);
  RenderStageOptions options;
  options.frames = 3;
  options.samples_per_pixel = 4;
  options.write_mp4 = true;
  RunRenderStage(dir_, options, record);
  for (const std::string kind : {"point", "env"}) {
    const fs::path dir = fs::path(dir_) / "relight/render" / ("turntable_" + kind);
    const Image frame = ReadImage((dir / "0001.exr").string());
    EXPECT_EQ(frame.channels(), 4);
    double alpha = 0;
    for (int y = 0; y < frame.height(); ++y) {
      for (int x = 0; x < frame.width(); ++x) alpha += frame.at(x, y, 3);
    }
    EXPECT_GT(alpha, 200.0) << kind;  // the object is in view
    EXPECT_TRUE(fs::exists(dir / "0002.png"));
    EXPECT_GT(fs::file_size(fs::path(dir_) / "relight/render" / ("turntable_" + kind + ".mp4")), 1000u);
  }
}

// An exported asset renders exactly like the workspace it came from.
TEST_F(RelightStageTest, ExportedAssetRendersBitIdenticallyToTheWorkspace) {
  RunRecord record("test");
  RunTrainStage(dir_, 0, SmallModel(), SmallTraining(10), true, record);
  const std::string asset_dir = dir_ + "/asset";
  ExportAsset(dir_, asset_dir, record);
  ASSERT_TRUE(fs::exists(asset_dir + "/manifest.json"));
  ASSERT_TRUE(fs::exists(asset_dir + "/proxy.obj"));
  ASSERT_FALSE(fs::exists(asset_dir + "/partitions/00/optimizer.pt"));
  EXPECT_EQ(ReadImage(asset_dir + "/textures/00.exr").channels(), 5 * SmallModel().channels_per_basis);

  const AssetDescription from_workspace = DescribeWorkspace(dir_);
  const Camera camera(from_workspace.camera,
                      LookAt(from_workspace.object_centre_m + Eigen::Vector3d(0.25, -0.2, 0.2),
                             from_workspace.object_centre_m, Eigen::Vector3d::UnitZ()));
  const nlohmann::json views = {
      {"views",
       {{{"name", "key"}, {"cam_from_world", ToJson(camera.cam_from_world())},
         {"light", {{"type", "point"}, {"position_m", {0.3, -0.1, 0.4}}, {"intensity", 1.0}}}},
        {{"name", "sun"}, {"cam_from_world", ToJson(camera.cam_from_world())},
         {"light", {{"type", "directional"}, {"direction_to_light", {0.2, -0.5, 1.0}}, {"irradiance", {3, 3, 2.5}}}}}}}};
  const std::string views_path = dir_ + "/views.json";
  std::ofstream(views_path) << views.dump(2);
  RenderStageOptions options;
  options.samples_per_pixel = 4;
  RunRenderViews(from_workspace, views_path, dir_ + "/from_workspace", options, record);
  RunRenderViews(ReadAsset(asset_dir), views_path, dir_ + "/from_asset", options, record);
  for (const std::string name : {"key", "sun"}) {
    const Image a = ReadImage(dir_ + "/from_workspace/" + name + ".exr");
    const Image b = ReadImage(dir_ + "/from_asset/" + name + ".exr");
    ASSERT_EQ(a.data().size(), b.data().size());
    EXPECT_TRUE(a.data() == b.data()) << name;
    double alpha = 0;
    for (int y = 0; y < a.height(); ++y) {
      for (int x = 0; x < a.width(); ++x) alpha += a.at(x, y, 3);
    }
    EXPECT_GT(alpha, 100.0) << name;
  }
}

AugmentOptions SmallAugment() {
  AugmentOptions a;
  a.maps = 6;
  a.map_width_px = 64;
  a.views = 3;
  a.maps_per_view = 2;
  a.directions = 8;
  a.samples_per_pixel = 2;
  a.map_samples_per_pixel = 4;
  a.steps = 10;
  return a;
}

// Lighting augmentation: augmented frames for views x maps, a fine-tuned
// model that continues the point-light one (and replaces it for rendering),
// an exact resume, and the linearity the method rests on.
TEST_F(RelightStageTest, AugmentFineTunesThePointLightModelUnderEnvironmentMaps) {
  RunRecord record("test");
  const TrainStageOptions training = SmallTraining(20);
  RunTrainStage(dir_, 0, SmallModel(), training, true, record);
  const auto start = std::chrono::steady_clock::now();
  const AugmentStageResult result = RunAugmentStage(dir_, 0, SmallAugment(), training, true, record);
  std::printf("augment: %.1f s\n", SecondsSince(start));
  EXPECT_EQ(result.views, 3);
  EXPECT_EQ(result.frames, 6);
  EXPECT_EQ(result.steps, 30);  // continues the point-light model's 20 steps
  EXPECT_GT(result.val_psnr_before_db, 0);
  EXPECT_GT(result.val_psnr_after_db, result.val_psnr_before_db - 0.5);  // captured frames do not degrade
  const fs::path dir = fs::path(dir_) / "relight/augment/00";
  ASSERT_TRUE(fs::exists(dir / "train.json"));
  std::vector<fs::path> targets;
  for (const auto& entry : fs::directory_iterator(dir / "frames")) {
    const std::string name = entry.path().filename().string();
    if (name.size() > 11 && name.substr(name.size() - 11) == ".target.exr") targets.push_back(entry.path());
  }
  ASSERT_EQ(targets.size(), 6u);
  const Image target = ReadImage(targets[0].string());
  ASSERT_EQ(target.channels(), 4);
  double lit = 0;
  for (size_t p = 0; p < target.pixel_count(); ++p) {
    const float* px = &target.data()[4 * p];
    ASSERT_TRUE(std::isfinite(px[0]) && px[0] >= 0 && px[3] >= 0 && px[3] <= 1.001f);
    lit += px[3] > 0.5f ? px[0] + px[1] + px[2] : 0;
  }
  EXPECT_GT(lit, 10.0);  // the object is lit under the map
  EXPECT_EQ(DescribeWorkspace(dir_).partition_models[0], (dir / "checkpoint").string());
  EXPECT_EQ(DescribeWorkspace(dir_, ModelSet::kPointLight).partition_models[0],
            (fs::path(dir_) / "relight/partitions/00/checkpoint").string());
  // With augmentation off (augment.enabled: false) the exported asset holds
  // the point-light model although this augment folder is current.
  {
    auto file = [](const fs::path& path) {
      std::ifstream in(path, std::ios::binary);
      return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const fs::path on = fs::path(dir_) / "asset_augment_on", off = fs::path(dir_) / "asset_augment_off";
    ExportAsset(dir_, on.string(), record, nullptr, FinalModels(true));
    ExportAsset(dir_, off.string(), record, nullptr, FinalModels(false));
    const std::string augmented = file(dir / "checkpoint" / "model.pt"),
                      point_light = file(fs::path(dir_) / "relight/partitions/00/checkpoint/model.pt");
    ASSERT_NE(augmented, point_light);
    EXPECT_EQ(file(on / "partitions/00/model.pt"), augmented);
    EXPECT_EQ(file(off / "partitions/00/model.pt"), point_light);
    fs::remove_all(on);
    fs::remove_all(off);
  }

  // Rerun: nothing to redo (frames kept, training already at its end).
  const auto written = fs::last_write_time(targets[0]);
  const AugmentStageResult again = RunAugmentStage(dir_, 0, SmallAugment(), training, false, record);
  EXPECT_EQ(again.resumed_from, 30);
  EXPECT_EQ(fs::last_write_time(targets[0]), written);

  // Light transport is linear: twice the map's light, twice the target and
  // twice the cues, with the same directions and seeds.
  AugmentOptions brighter = SmallAugment();
  brighter.exposure = 2.0;
  const Image cues_before = ReadCueFrame(targets[0].string().substr(0, targets[0].string().size() - 11) + ".cues.exr");
  RunAugmentStage(dir_, 0, brighter, training, false, record);
  const Image target2 = ReadImage(targets[0].string());
  const Image cues2 = ReadCueFrame(targets[0].string().substr(0, targets[0].string().size() - 11) + ".cues.exr");
  double sum1 = 0, sum2 = 0, cue1 = 0, cue_2 = 0;
  for (size_t p = 0; p < target.pixel_count(); ++p) {
    if (target.data()[4 * p + 3] < 0.5f) continue;
    for (int c = 0; c < 3; ++c) sum1 += target.data()[4 * p + c], sum2 += target2.data()[4 * p + c];
    cue1 += cues_before.data()[22 * p];
    cue_2 += cues2.data()[22 * p];
  }
  EXPECT_NEAR(sum2 / sum1, 2.0, 0.01);  // half-float storage
  EXPECT_NEAR(cue_2 / cue1, 2.0, 0.01);

  // The partition trained again (other steps): the augment folder was
  // fine-tuned from the old point-light model and is stale, so the final
  // model set falls back to the new point-light model until augment reruns.
  RunTrainStage(dir_, 0, SmallModel(), SmallTraining(24), true, record);
  EXPECT_EQ(DescribeWorkspace(dir_).partition_models[0],
            (fs::path(dir_) / "relight/partitions/00/checkpoint").string());
  RunAugmentStage(dir_, 0, brighter, SmallTraining(24), false, record);
  EXPECT_EQ(DescribeWorkspace(dir_).partition_models[0], (dir / "checkpoint").string());
}

// cues.secondary_material fitted: the cue stage renders the frames with the
// basis, fits the cue weights, and renders them again with the proxy
// wearing that mixture past the primary hit. The fitted Lambert weights are
// reflectances (the flash's scale divided out: the tiny capture's flash is
// not the cue light's 1 W/sr), so at the frame's pixels they read the spot
// texture's diffuse albedo; and the cow's own bounce light, which the basis
// renders as if the cow were white, is dimmer in the fitted frames.
TEST(RelightStageFitted, SecondaryMaterialIsTheFitsReflectanceAndDimsTheBounceLight) {
  const fs::path dir = fs::temp_directory_path() / ("relit_relight_fitted_" + std::to_string(::getpid()));
  testing::TestWorkspaceOptions o;
  o.frames = 16;
  o.proxy_offset_m = 0;
  testing::MakeTestWorkspace(dir.string(), o);
  CueStageOptions options;
  options.samples_per_pixel = 8;
  RunRecord record("test");
  RunCueStage(dir.string(), options, record);
  const CuesFile basis_file = ReadCuesFile((dir / "relight/cues/cues.json").string());
  EXPECT_TRUE(basis_file.cue_weights.empty());
  const Image basis = ReadCueFrame((dir / basis_file.frames[3].file).string());
  options.secondary_material = "fitted";
  RunRecord fitted_record("test");
  testing::RunCuesAndSinglePartitionPlan(dir.string(), options, fitted_record);
  const CuesFile cues = ReadCuesFile((dir / "relight/cues/cues.json").string());
  ASSERT_EQ(cues.cue_weights, "relight/cues/proxy_cue_weights.exr");
  EXPECT_FALSE(fs::exists(dir / "relight/cues/basis"));  // the first rendering is not kept
  const Image weights = ReadCueWeights((dir / cues.cue_weights).string());
  const Image fitted = ReadCueFrame((dir / cues.frames[3].file).string());

  synth::SynthOptions synth_options = synth::SynthOptions::ForSize("tiny");
  const synth::SynthScene scene = synth::BuildScene("spot", synth_options.board, synth::DefaultAssetsDir());
  const render::Material* truth = nullptr;
  for (const synth::SynthObject& object : scene.objects) {
    if (object.foreground) truth = &object.material;
  }
  ASSERT_NE(truth, nullptr);
  const render::Texture lambert =
      render::Texture::FromImage(weights.SelectChannels(std::vector<int>{0, 1, 2}), false);
  std::vector<double> ratio[3];
  double basis_bounce = 0, fitted_bounce = 0;
  for (int y = 0; y < fitted.height(); ++y) {
    for (int x = 0; x < fitted.width(); ++x) {
      if (fitted.at(x, y, 21) < 1) continue;
      const render::Vec2f uv(fitted.at(x, y, 15), fitted.at(x, y, 16));
      const render::Rgb w = lambert.Eval(uv), albedo = truth->diffuse_albedo.Eval(uv);
      for (int c = 0; c < 3; ++c) {
        if (albedo[c] > 0.05f) ratio[c].push_back(w[c] / albedo[c]);
        basis_bounce += basis.at(x, y, c);
        fitted_bounce += fitted.at(x, y, c);
      }
    }
  }
  ASSERT_GT(ratio[0].size(), 300u);
  for (int c = 0; c < 3; ++c) {
    const double median = Median(ratio[c]);
    std::printf("channel %d: fitted Lambert / true diffuse albedo, median %.3f over %zu pixels\n", c, median,
                ratio[c].size());
    EXPECT_NEAR(median, 1.0, 0.1) << c;  // measured 0.96-0.98
  }
  std::printf("Lambert cue sum: basis %.2f, fitted %.2f\n", basis_bounce, fitted_bounce);
  EXPECT_LT(fitted_bounce, 0.995 * basis_bounce);

  // The exported asset carries the weights: its cue scene renders frame 3's
  // cues again (the stage's seed for it) as the stage did.
  RunTrainStage(dir.string(), 0, SmallModel(), SmallTraining(2), false, fitted_record);
  ExportAsset(dir.string(), (dir / "asset").string(), fitted_record);
  const AssetDescription asset = ReadAsset((dir / "asset").string());
  ASSERT_EQ(asset.cue_weights, (dir / "asset" / "proxy_cue_weights.exr").string());
  const auto asset_scene = LoadProxyScene(asset.mesh, asset.support_plane, asset.normal_map, asset.cue_weights);
  const Image again = RenderCueFrame(*asset_scene, Camera(cues.camera, cues.frames[3].cam_from_world),
                                     CueLight::Point(cues.frames[3].light_position_m, options.flash_intensity),
                                     CueFrameRenderSettings(options, 3));
  double again_bounce = 0;
  for (int y = 0; y < again.height(); ++y) {
    for (int x = 0; x < again.width(); ++x) {
      if (fitted.at(x, y, 21) < 1) continue;
      for (int c = 0; c < 3; ++c) again_bounce += again.at(x, y, c);
    }
  }
  EXPECT_NEAR(again_bounce, fitted_bounce, 1e-3 * fitted_bounce);
  fs::remove_all(dir);
}

TEST(RelightStageErrors, MissingUpstreamOutputsNameTheStageToRun) {
  const std::string dir = (fs::temp_directory_path() / ("relit_relight_err_" + std::to_string(::getpid()))).string();
  fs::create_directories(dir);
  RunRecord record("test");
  try {
    RunCueStage(dir, CueStageOptions(), record);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("calib"), std::string::npos) << e.what();
  }
  try {
    RunTrainStage(dir, 0, SmallModel(), SmallTraining(1), false, record);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("relit-relight plan"), std::string::npos) << e.what();
  }
  try {
    RunAugmentStage(dir, 0, SmallAugment(), SmallTraining(1), false, record);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("relit-relight plan"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

// A views file that would render nothing useful, silently overwrite an image
// or light with negative power, and --out paths that would lose files, are
// refused before anything renders (docs/refusals.md).
TEST(RelightStageErrors, RenderViewsRefusesBadViewsAndUnsafeOutputs) {
  const fs::path dir = fs::temp_directory_path() / ("relit_relight_views_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  AssetDescription asset;  // no models: every check below comes before the renderer
  asset.camera.width = 32;
  asset.camera.height = 24;
  asset.camera.fx = asset.camera.fy = 30;
  asset.mesh = (dir / "proxy.obj").string();
  auto error_of = [&](const std::string& views, const fs::path& out) {
    const fs::path file = dir / "views.json";
    std::ofstream(file) << views;
    RunRecord record("test");
    try {
      RunRenderViews(asset, file.string(), out.string(), RenderStageOptions(), record);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const std::string pose = R"("cam_from_world": {"rotation_wxyz": [1, 0, 0, 0], "translation_m": [0, 0, 0.5]})";
  auto view = [&](const std::string& name, const std::string& light) {
    return R"({"name": ")" + name + "\", " + pose + R"(, "light": )" + light + "}";
  };
  const std::string point = R"({"type": "point", "position_m": [0, 0, 1], "intensity": 1})";
  const fs::path out = dir / "out";
  EXPECT_NE(error_of(R"({"views": []})", out).find("empty"), std::string::npos);
  EXPECT_NE(error_of(R"({"views": [)" + view("a", point) + ", " + view("a", point) + "]}", out).find("also the name"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"views": [)" + view("a", R"({"type": "point", "position_m": [0, 0, 1], "intensity": -2})") +
                         "]}", out).find("intensity: must be finite and >= 0"),
            std::string::npos);
  EXPECT_NE(error_of(R"({"views": [)" +
                         view("a", R"({"type": "directional", "direction_to_light": [0, 0, 0]})") + "]}", out)
                .find("direction_to_light: is zero"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(out));
  // A file as --out, and a folder holding the views file.
  std::ofstream(dir / "notes.txt") << "mine";
  const std::string good = R"({"views": [)" + view("a", point) + "]}";
  EXPECT_NE(error_of(good, dir / "notes.txt").find("never replaces a file"), std::string::npos);
  EXPECT_NE(error_of(good, dir).find("holds the input"), std::string::npos);
  std::ifstream in(dir / "notes.txt");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()), "mine");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace relit::relight
