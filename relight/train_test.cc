// Training behaviour: the model learns a tiny synthetic problem, and
// checkpoints resume exactly.
#include <chrono>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/options.h"
#include "core/run_record.h"
#include "relight/checkpoint.h"
#include "relight/dataset.h"
#include "relight/model.h"
#include "relight/cues_baseline.h"
#include "relight/warm_start.h"
#include "relight/test_scene.h"
#include "relight/train_loop.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;

std::vector<Batch> Frames(int count, int size, uint64_t seed) {
  const auto material = testing::SyntheticMaterial(seed);
  std::vector<Batch> frames;
  for (int f = 0; f < count; ++f) frames.push_back(testing::SyntheticFrame(material, size, f, seed + 1));
  return frames;
}

// Mean of v[from, from + window): loss levels at the start and end of a run.
double WindowMean(const std::vector<double>& v, int from, int window) {
  double sum = 0;
  for (int i = from; i < from + window; ++i) sum += v[i];
  return sum / window;
}

double MaxRadiance(const std::vector<Batch>& frames) {
  double m = 0;
  for (const auto& f : frames) m = std::max(m, f.target_rgb.max().item<double>());
  return m;
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("relit_relight_test_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(TrainTest, OverfitsATinySyntheticProblem) {
  const std::vector<Batch> frames = Frames(4, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.variant = "dnl";  // DNL's networks alone, from random texels
  model_options.object_window_margin_px = 0;
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.crop_px = 0;
  train_options.learning_rate = 2e-3;  // faster than DNL's 2e-4 so the test stays short
  train_options.seed = 3;
  train_options.threads = 1;  // tiny tensors: a second thread only adds barrier waits
  Trainer trainer(model_options, train_options);
  const int steps = 300, window = 20;
  std::vector<double> total, rgb;
  const auto start = std::chrono::steady_clock::now();
  for (int s = 0; s < steps; ++s) {
    const Losses losses = trainer.Step(frames[s % frames.size()]);
    total.push_back(losses.total.item<double>());
    rgb.push_back(losses.rgb.item<double>());
    ASSERT_TRUE(std::isfinite(total.back())) << "step " << s;
  }
  const double seconds = SecondsSince(start);
  auto mean = [&](const std::vector<double>& v, int from) { return WindowMean(v, from, window); };
  const double first = mean(total, 0), last = mean(total, steps - window);
  const double first_rgb = mean(rgb, 0), last_rgb = mean(rgb, steps - window);
  std::printf("loss %.4f -> %.4f (x%.1f), rgb %.4f -> %.4f (x%.1f), %d steps in %.1f s\n", first, last,
              first / last, first_rgb, last_rgb, first_rgb / last_rgb, steps, seconds);
  EXPECT_EQ(trainer.step(), steps);
  EXPECT_GT(first / last, 5.0);
  EXPECT_GT(first_rgb / last_rgb, 3.0);

  // The learned renders match the targets in linear space, too.
  const auto rgba = trainer.model()->Render(frames[0]);
  const auto matte = frames[0].target_matte;
  const double error = ((rgba.slice(1, 0, 3) - frames[0].target_rgb).abs() * matte).sum().item<double>() /
                       (3 * matte.sum().item<double>());
  const double scale = (frames[0].target_rgb * matte).sum().item<double>() / (3 * matte.sum().item<double>());
  EXPECT_LT(error, 0.2 * scale);
}

// The sh baseline (cues.input: sh) learns its tiny problem through the SH
// light channels. Measured (seed 3, 300 steps): total loss falls 19x, the
// rgb loss 10.5x; asserted > 8x and > 5x.
TEST(TrainTest, ShModelOverfitsATinyProblem) {
  const auto material = testing::SyntheticMaterial(41);
  std::vector<Batch> frames;
  for (int f = 0; f < 4; ++f) frames.push_back(testing::SyntheticShFrame(material, 32, f, 42));
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.format.input = CueFormat::kSh;
  model_options.variant = "dnl";
  model_options.object_window_margin_px = 0;
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.crop_px = 0;
  train_options.learning_rate = 2e-3;
  train_options.seed = 3;
  train_options.threads = 1;
  Trainer trainer(model_options, train_options);
  EXPECT_EQ(trainer.model()->texture()->texels().size(1), 21 + model_options.channels_per_basis);
  const int steps = 300, window = 20;
  std::vector<double> total, rgb;
  for (int s = 0; s < steps; ++s) {
    const Losses losses = trainer.Step(frames[s % frames.size()]);
    total.push_back(losses.total.item<double>());
    rgb.push_back(losses.rgb.item<double>());
    ASSERT_TRUE(std::isfinite(total.back())) << "step " << s;
  }
  auto mean = [&](const std::vector<double>& v, int from) { return WindowMean(v, from, window); };
  const double first = mean(total, 0), last = mean(total, steps - window);
  const double first_rgb = mean(rgb, 0), last_rgb = mean(rgb, steps - window);
  std::printf("sh: loss %.4f -> %.4f (x%.1f), rgb %.4f -> %.4f (x%.1f)\n", first, last, first / last, first_rgb,
              last_rgb, first_rgb / last_rgb);
  EXPECT_GT(first / last, 8.0);
  EXPECT_GT(first_rgb / last_rgb, 5.0);
  // Radiance-cue batches (15 channels) do not fit the sh model: a clear error.
  const auto cue_frame = testing::SyntheticFrame(material, 32, 0, 42);
  EXPECT_THROW(trainer.Step(cue_frame), Error);
}

// The basis set and input travel with the checkpoint; a mismatch is an error.
TEST(CheckpointTest, RecordsTheInputFormatAndRefusesAnother) {
  const auto material = testing::SyntheticMaterial(5);
  std::vector<Batch> frames = {testing::SyntheticFrame(material, 16, 0, 6)};
  frames[0].cues = frames[0].cues.slice(1, 0, 3).contiguous();  // Lambert only
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.format.bases = {"lambert"};
  model_options.variant = "dnl";  // the residual variant needs the 5 default cues
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.crop_px = 0;
  Trainer trainer(model_options, train_options);
  EXPECT_EQ(trainer.model()->texture()->texels().size(1), model_options.channels_per_basis);
  trainer.Step(frames[0]);
  TempDir temp;
  const fs::path dir = temp.path() / "one_basis";
  SaveCheckpoint(dir, trainer);
  const CheckpointInfo info = ReadCheckpointInfo(dir);
  EXPECT_EQ(info.model_options.format, model_options.format);
  EXPECT_EQ(LoadModel(dir)->options().format.bases, std::vector<std::string>{"lambert"});
  EXPECT_NO_THROW(RequireCheckpointFormat(dir, model_options.format));
  try {
    RequireCheckpointFormat(dir, CueFormat{});
    ADD_FAILURE() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1 basis (lambert)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("5 bases"), std::string::npos) << e.what();
  }
  // A 5-basis batch into the 1-basis model is refused, not silently misread.
  EXPECT_THROW(LoadModel(dir)->Render(testing::SyntheticFrame(material, 16, 0, 6)), Error);
  // Default models write no format keys (older checkpoints read as the default).
  EXPECT_FALSE(OptionsToJson(testing::TinyModelOptions()).contains("input"));
  EXPECT_TRUE(OptionsToJson(model_options).contains("bases"));
}

TEST(CheckpointTest, ResumingReproducesTheUninterruptedRun) {
  const std::vector<Batch> frames = Frames(2, 32, 31);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.crop_px = 16;  // crops exercise the saved generator state
  train_options.learning_rate = 1e-3;
  train_options.seed = 7;
  const int k = 5;
  auto run = [&](Trainer& trainer, int steps) {
    std::vector<float> losses;
    for (int s = 0; s < steps; ++s) {
      losses.push_back(trainer.Step(frames[trainer.step() % frames.size()]).total.item<float>());
    }
    return losses;
  };

  Trainer straight(model_options, train_options);
  const std::vector<float> expected = run(straight, 2 * k);

  TempDir temp;
  const fs::path dir = temp.path() / "ckpt";
  Trainer first_half(model_options, train_options);
  first_half.set_clip_overshoot(1.25);  // the warm start's lift travels with the checkpoint
  first_half.set_clip_noise(0.07);      // and so does its censored model's noise
  std::vector<float> resumed = run(first_half, k);
  SaveCheckpoint(dir, first_half);
  const auto before_resume = first_half.model()->Render(frames[0]);

  const CheckpointInfo info = ReadCheckpointInfo(dir);
  EXPECT_EQ(info.step, k);
  EXPECT_EQ(info.clip_overshoot, 1.25);
  EXPECT_EQ(info.clip_noise, 0.07);
  EXPECT_EQ(OptionsToJson(info.model_options), OptionsToJson(model_options));
  EXPECT_EQ(OptionsToJson(info.train_options), OptionsToJson(train_options));

  std::unique_ptr<Trainer> second_half = LoadTrainer(dir);
  EXPECT_EQ(second_half->step(), k);
  EXPECT_EQ(second_half->clip_overshoot(), 1.25);
  EXPECT_EQ(second_half->clip_noise(), 0.07);
  for (float loss : run(*second_half, k)) resumed.push_back(loss);
  ASSERT_EQ(resumed.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(resumed[i], expected[i], 1e-6) << "step " << i;
  }
  EXPECT_TRUE(torch::equal(second_half->model()->texture()->texels(), straight.model()->texture()->texels()));

  // A model-only load renders like the saved trainer.
  DnlModel model = LoadModel(dir);
  EXPECT_TRUE(torch::equal(model->Render(frames[0]), before_resume));

  // Without the optimiser state the continuation differs: the test can see it.
  Trainer fresh_optimizer(model_options, train_options);
  torch::load(fresh_optimizer.model(), (dir / "model.pt").string());
  fresh_optimizer.set_step(k);
  const std::vector<float> diverged = run(fresh_optimizer, k);
  double max_difference = 0;
  for (int i = 0; i < k; ++i) max_difference = std::max(max_difference, std::abs(double(diverged[i]) - expected[k + i]));
  EXPECT_GT(max_difference, 1e-5);

  // Saving again replaces the checkpoint; a foreign schema is refused.
  SaveCheckpoint(dir, *second_half);
  EXPECT_EQ(ReadCheckpointInfo(dir).step, 2 * k);
  std::ofstream(dir / "checkpoint.json") << R"({"schema": "relit.checkpoint/9", "step": 1})";
  EXPECT_THROW(ReadCheckpointInfo(dir), Error);
  EXPECT_THROW(LoadTrainer(temp.path() / "missing"), Error);
}

// `model` renders every 32 x 32 frame's target: mean absolute error inside
// the coverage below `relative_error` x the target's mean there, and, when
// `alpha_error` > 0, alpha within that of the coverage everywhere.
void ExpectRendersTargets(DnlModel& model, const std::vector<Batch>& frames, double relative_error,
                          double alpha_error = 0, double min_coverage = 0.5) {
  for (const Batch& f : frames) {
    const auto rgba = model->Render(f);
    const auto inside = f.coverage > min_coverage;
    const auto error = (rgba.slice(1, 0, 3) - f.target_rgb).abs().masked_select(inside.expand({1, 3, 32, 32}));
    const double scale = f.target_rgb.masked_select(inside.expand({1, 3, 32, 32})).mean().item<double>();
    EXPECT_LT(error.mean().item<double>(), relative_error * scale);
    if (alpha_error > 0) {
      EXPECT_LT((rgba.slice(1, 3, 4) - f.coverage).abs().max().item<double>(), alpha_error);
    }
  }
}

// The residual variant's warm start on frames whose targets are exactly a
// per-texel linear model of the cues: the least-squares fit recovers it, and
// the step-0 model renders the targets with the proxy's coverage as alpha.
TEST(ResidualModelTest, WarmStartReproducesALinearCueModelAndTheCoverage) {
  std::vector<Batch> frames = Frames(12, 32, 31);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.texture_resolution_px = 8;
  model_options.cue_fit = "per_texel";
  torch::manual_seed(7);
  const auto weights = torch::rand({1, 15, 8, 8});
  for (Batch& f : frames) {
    f.target_rgb = CueRegression(SampleNearest(weights, f.uv, f.coverage), f.cues).clamp_min(0.0);
  }
  model_options.max_radiance = MaxRadiance(frames);
  DnlModel model(model_options);
  // A weak ridge: the synthetic blobs make the 5 cues nearly collinear.
  const WarmStartResult fit = WarmStartCueRegression(model, frames, CueFitOptions{}, 1e-4);
  std::printf("warm start: %lld pixels, %lld of %lld texels seen\n", static_cast<long long>(fit.stats.pixels),
              static_cast<long long>(fit.stats.texels_seen), static_cast<long long>(fit.texels));
  EXPECT_GT(fit.stats.pixels, 12 * 500);
  ExpectRendersTargets(model, frames, 0.01, 2e-3);
  // Texels seen by many pixels hold the true weights.
  const auto seen = (model->regression() - weights).abs().amax(1).flatten();
  EXPECT_LT(std::get<0>(seen.sort()).slice(0, 0, fit.stats.texels_seen / 2).max().item<double>(), 0.02);
}

// The default (smooth) warm start on frames whose targets are a smooth,
// bilinearly read linear model of the cues: the fit recovers them and the
// step-0 model renders the targets.
TEST(ResidualModelTest, SmoothWarmStartReproducesASmoothLinearCueModel) {
  std::vector<Batch> frames = Frames(12, 32, 31);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.texture_resolution_px = 8;
  ASSERT_EQ(model_options.cue_fit, "smooth");
  torch::manual_seed(7);
  // Weights that vary smoothly over the atlas: a 2x2 grid read bilinearly at 8x8.
  const auto coarse = torch::rand({1, 15, 2, 2});
  const auto weights = torch::nn::functional::interpolate(
      coarse, torch::nn::functional::InterpolateFuncOptions().size(std::vector<int64_t>{8, 8}).mode(torch::kBilinear).align_corners(false));
  for (Batch& f : frames) {
    f.target_rgb = CueRegression(SampleBilinear(weights, f.uv, f.coverage), f.cues).clamp_min(0.0);
  }
  model_options.max_radiance = MaxRadiance(frames);
  DnlModel model(model_options);
  CueFitOptions fit_options;
  fit_options.iterations_per_level = 300;
  const WarmStartResult fit = WarmStartCueRegression(model, frames, fit_options);
  EXPECT_GT(fit.stats.pixels, 12 * 500);
  EXPECT_GT(fit.stats.iterations, 0);
  ExpectRendersTargets(model, frames, 0.02);
}

// Silhouette pixels the proxy covers in part: the path-traced cues carry
// the coverage (missed paths add nothing) and so does the video (the
// object over a dark room). The step-0 model renders them as the cue fit
// predicts them, not darker by the coverage once or twice more.
TEST(ResidualModelTest, RendersPartlyCoveredPixelsAsTheCueFitPredicts) {
  std::vector<Batch> frames = Frames(12, 32, 31);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.texture_resolution_px = 8;
  torch::manual_seed(7);
  const auto weights = torch::nn::functional::interpolate(
      torch::rand({1, 15, 2, 2}),
      torch::nn::functional::InterpolateFuncOptions().size(std::vector<int64_t>{8, 8}).mode(torch::kBilinear).align_corners(false));
  for (Batch& f : frames) {
    // The disk's outer ring of pixels (a neighbour outside it) covered 30 %.
    const auto outside = 1.0 - f.coverage;
    const auto near_outside = torch::max_pool2d(outside, 3, 1, 1) > 0;
    const auto partial = torch::where(near_outside & (f.coverage > 0), torch::full_like(f.coverage, 0.3), f.coverage);
    f.cues = f.cues * partial;
    f.coverage = partial;
    f.target_matte = partial;
    f.target_rgb = CueRegression(SampleBilinear(weights, f.uv, (partial > 0).to(torch::kFloat)), f.cues).clamp_min(0.0);
  }
  ASSERT_GT((frames[0].coverage == 0.3f).sum().item<int64_t>(), 50);
  model_options.max_radiance = MaxRadiance(frames);
  DnlModel model(model_options);
  CueFitOptions fit_options;
  fit_options.iterations_per_level = 300;
  WarmStartCueRegression(model, frames, fit_options);
  ExpectRendersTargets(model, frames, 0.02, 0, /*min_coverage=*/0.0);
  // The ring alone, against its own (dim) targets.
  for (const Batch& f : frames) {
    const auto ring = (f.coverage == 0.3f).expand({1, 3, 32, 32});
    const auto rgb = model->Render(f).slice(1, 0, 3);
    const double error = (rgb - f.target_rgb).abs().masked_select(ring).mean().item<double>();
    EXPECT_LT(error, 0.05 * f.target_rgb.masked_select(ring).mean().item<double>());
  }
}

// From the warm start, training the corrections lowers the loss on the
// nonlinear (power 0.8) tiny problem, which no linear cue model fits.
TEST(ResidualModelTest, CorrectionsImproveOnTheCueRegression) {
  std::vector<Batch> frames = Frames(4, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.learning_rate = 2e-3;
  train_options.seed = 3;
  train_options.threads = 1;
  Trainer trainer(model_options, train_options);
  WarmStartCueRegression(trainer.model(), frames, train_options.cue_fit);
  auto rgb_loss = [&] {
    double sum = 0;
    torch::NoGradGuard no_grad;
    for (const Batch& f : frames) sum += trainer.model()->Loss(trainer.model()->Forward(f), f).rgb.item<double>();
    return sum / frames.size();
  };
  const double before = rgb_loss();
  for (int s = 0; s < 150; ++s) trainer.Step(frames[s % frames.size()]);
  const double after = rgb_loss();
  std::printf("residual rgb loss %.4f -> %.4f (x%.1f)\n", before, after, before / after);
  EXPECT_GT(before / after, 1.5);
}

// A correction that hurts on held-out frames is switched off; one that
// helps is kept, and the chosen model is never worse than the trained one.
TEST(ResidualModelTest, KeepsOnlyCorrectionsThatHelpOnValidationFrames) {
  std::vector<Batch> frames = Frames(4, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  TrainOptions train_options;
  train_options.threads = 1;
  Trainer trainer(model_options, train_options);
  WarmStartCueRegression(trainer.model(), frames, train_options.cue_fit);
  {
    torch::NoGradGuard no_grad;
    for (torch::Tensor gate : trainer.model()->gates()) gate.fill_(25.0);  // untrained networks at full strength
  }
  const CorrectionChoice harmful = KeepHelpfulCorrections(trainer.model(), frames);
  EXPECT_FALSE(harmful.renderer_kept);
  EXPECT_GT(harmful.without_renderer.psnr_db, harmful.trained.psnr_db);
  EXPECT_GE(harmful.chosen.psnr_db, harmful.trained.psnr_db);
  EXPECT_EQ(trainer.model()->gates()[0].item<double>(), 0.0);
  if (!harmful.mask_kept) {
    EXPECT_EQ(trainer.model()->gates()[1].item<double>(), 0.0);
  }

  Trainer helped(model_options, train_options);
  WarmStartCueRegression(helped.model(), frames, train_options.cue_fit);
  for (int s = 0; s < 150; ++s) helped.Step(frames[s % frames.size()]);
  const double gate = helped.model()->gates()[0].item<double>();
  const CorrectionChoice useful = KeepHelpfulCorrections(helped.model(), frames);
  std::printf("trained renderer correction: %.2f dB with, %.2f dB without\n", useful.trained.psnr_db,
              useful.without_renderer.psnr_db);
  EXPECT_TRUE(useful.renderer_kept);
  EXPECT_EQ(helped.model()->gates()[0].item<double>(), gate);
}

// The residual variant's mask network corrects the coverage only within
// model.mask_band_px of it: farther out alpha is exactly 0, however large
// the (here untrained, full-strength) correction.
TEST(ResidualModelTest, MaskCorrectsOnlyNearTheCoverage) {
  std::vector<Batch> frames = Frames(2, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  model_options.object_window_margin_px = 0;
  model_options.mask_correction = true;
  model_options.mask_band_px = 2;
  DnlModel model(model_options);
  {
    torch::NoGradGuard no_grad;
    for (torch::Tensor gate : model->gates()) gate.fill_(25.0);
  }
  const auto coverage = frames[0].coverage[0][0];
  const auto alpha = model->Render(frames[0])[0][3];
  int far = 0, near_changed = 0;
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      bool near = false;  // a covered pixel within 2 px (square window)
      for (int v = std::max(0, y - 2); v <= std::min(31, y + 2); ++v) {
        for (int u = std::max(0, x - 2); u <= std::min(31, x + 2); ++u) near |= coverage[v][u].item<float>() > 0;
      }
      const double a = alpha[y][x].item<double>();
      if (!near) {
        ++far;
        EXPECT_LT(a, 1e-9) << x << "," << y;
      } else if (std::abs(a - coverage[y][x].item<double>()) > 0.01) {
        ++near_changed;
      }
    }
  }
  EXPECT_GT(far, 50);
  EXPECT_GT(near_changed, 10);  // the correction acts inside the band
}

// Without model.mask_correction (the default) the residual model has no mask
// network: its alpha is the coverage, whatever the gates, and the mask loss
// is 0, so training moves nothing for it.
TEST(ResidualModelTest, WithoutTheMaskCorrectionAlphaIsTheCoverage) {
  std::vector<Batch> frames = Frames(2, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  model_options.object_window_margin_px = 0;
  ASSERT_FALSE(model_options.mask_correction);
  DnlModel model(model_options);
  EXPECT_FALSE(model->has_mask_net());
  {
    torch::NoGradGuard no_grad;
    for (torch::Tensor gate : model->gates()) gate.fill_(25.0);
  }
  const auto coverage = frames[0].coverage[0][0];
  const auto alpha = model->Render(frames[0])[0][3];
  EXPECT_LT((alpha - coverage).abs().max().item<double>(), 1e-5);
  const auto full_or_none = (coverage <= 0) | (coverage >= 1);  // no clamp there: sigmoid(+-30)
  ASSERT_GT(full_or_none.sum().item<int64_t>(), 0);
  EXPECT_LT((alpha - coverage).masked_select(full_or_none).abs().max().item<double>(), 1e-12);
  const Losses losses = model->Loss(model->Forward(frames[0]), frames[0], 1.0, 0.0);
  EXPECT_EQ(losses.mask.item<double>(), 0.0);
  EXPECT_NEAR(losses.total.item<double>(), losses.rgb.item<double>(), 1e-7);

  model_options.mask_correction = true;
  DnlModel corrected(model_options);
  EXPECT_TRUE(corrected->has_mask_net());
  EXPECT_GT(corrected->Loss(corrected->Forward(frames[0]), frames[0], 1.0, 0.0).mask.item<double>(), 0.0);
}

// train.matte_threshold: mattes become 0/1 at the threshold; 0 keeps them.
TEST(DatasetTest, ThresholdMattesAtTheGivenAlpha) {
  std::vector<Batch> frames(1);
  frames[0].target_matte = torch::tensor({0.0, 0.2, 0.5, 0.7, 1.0}).reshape({1, 1, 1, 5});
  std::vector<Batch> soft = frames;
  ThresholdMattes(soft, 0.0);
  EXPECT_TRUE(torch::equal(soft[0].target_matte, frames[0].target_matte));
  ThresholdMattes(frames, 0.5);
  EXPECT_TRUE(torch::equal(frames[0].target_matte, torch::tensor({0.0, 0.0, 1.0, 1.0, 1.0}).reshape({1, 1, 1, 5})));
}

// Checkpoints written before the variants existed hold DNL models.
TEST(CheckpointTest, OlderCheckpointsLoadAsDnl) {
  TempDir dir;
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.variant = "dnl";
  model_options.object_window_margin_px = 0;
  Trainer trainer(model_options, TrainOptions());
  const fs::path checkpoint = dir.path() / "checkpoint";
  SaveCheckpoint(checkpoint, trainer);
  const fs::path info_path = checkpoint / "checkpoint.json";
  nlohmann::json info = nlohmann::json::parse(std::ifstream(info_path));
  info["model_options"].erase("variant");
  info["model_options"].erase("object_window_margin_px");
  std::ofstream(info_path) << info.dump(2);
  const DnlModel loaded = LoadModel(checkpoint);
  EXPECT_EQ(loaded->options().variant, "dnl");
  EXPECT_EQ(loaded->options().object_window_margin_px, 0);
}

// Checkpoints from before cue_fit.clip_model lifted clipped readings: they
// read as "lift" (eval then does not take their warm start for a censored
// fit), and without clip_noise their loss keeps the bounds.
TEST(CheckpointTest, OlderCheckpointsFittedClippedReadingsWithTheLift) {
  TempDir dir;
  ModelOptions model_options = testing::TinyModelOptions();
  TrainOptions train_options;
  train_options.cue_fit.clip_model = "censored";
  Trainer trainer(model_options, train_options);
  trainer.set_clip_noise(0.1);
  const fs::path checkpoint = dir.path() / "checkpoint";
  SaveCheckpoint(checkpoint, trainer);
  const fs::path info_path = checkpoint / "checkpoint.json";
  nlohmann::json info = nlohmann::json::parse(std::ifstream(info_path));
  ASSERT_EQ(info["train_options"]["cue_fit"]["clip_model"], "censored");
  EXPECT_EQ(ReadCheckpointInfo(checkpoint).clip_noise, 0.1);
  info["train_options"]["cue_fit"].erase("clip_model");
  info.erase("clip_noise");
  std::ofstream(info_path) << info.dump(2);
  const CheckpointInfo read = ReadCheckpointInfo(checkpoint);
  EXPECT_EQ(read.train_options.cue_fit.clip_model, "lift");
  EXPECT_EQ(read.clip_noise, 0.0);
}

// Residual checkpoints from before model.mask_correction hold a mask network:
// they load with it, and alpha stays what it was.
TEST(CheckpointTest, OlderResidualCheckpointsKeepTheirMaskNetwork) {
  TempDir dir;
  std::vector<Batch> frames = Frames(2, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  model_options.object_window_margin_px = 0;
  model_options.mask_correction = true;
  Trainer trainer(model_options, TrainOptions());
  {
    torch::NoGradGuard no_grad;
    for (torch::Tensor gate : trainer.model()->gates()) gate.fill_(25.0);
  }
  const fs::path checkpoint = dir.path() / "checkpoint";
  SaveCheckpoint(checkpoint, trainer);
  const fs::path info_path = checkpoint / "checkpoint.json";
  nlohmann::json info = nlohmann::json::parse(std::ifstream(info_path));
  info["model_options"].erase("mask_correction");
  std::ofstream(info_path) << info.dump(2);
  DnlModel loaded = LoadModel(checkpoint);
  EXPECT_TRUE(loaded->has_mask_net());
  EXPECT_TRUE(torch::allclose(loaded->Render(frames[0]), trainer.model()->Render(frames[0])));
}

// The output blur: within the coverage, alpha untouched, a constant colour
// kept to the rim, and its width in pixels the texels over the footprint.
TEST(OutputBlurTest, BlursColourWithinTheCoverageByTexelsOverTheFootprint) {
  const int size = 64;
  Batch batch = testing::RandomBatch(size);
  const float texels_per_px = 2.0f;
  const int64_t resolution = 256;
  batch.uv_derivatives = torch::tensor({texels_per_px / resolution, 0.0f, 0.0f, texels_per_px / resolution})
                             .view({1, 1, 1, 4}).expand({1, size, size, 4}).contiguous();
  const auto y = torch::arange(size).view({size, 1}).expand({size, size}).to(torch::kFloat) - 31.5f;
  const auto x = torch::arange(size).view({1, size}).expand({size, size}).to(torch::kFloat) - 31.5f;
  const auto inside = ((x * x + y * y) < 25.0f * 25.0f).to(torch::kFloat).view({1, 1, size, size});
  batch.coverage = inside;
  // A constant colour over the disc: the blur keeps it, alpha and the outside stay.
  const auto colour = torch::tensor({0.2f, 0.5f, 0.9f}).view({1, 3, 1, 1});
  const auto flat = torch::cat({colour * inside, inside}, 1);
  const auto flat_blurred = BlurWithinCoverage(flat, batch, 4.0, resolution);
  EXPECT_TRUE(torch::allclose(flat_blurred, flat, 1e-5, 1e-5));
  EXPECT_TRUE(torch::equal(BlurWithinCoverage(flat, batch, 0.0, resolution), flat));
  // An impulse in the middle spreads as a Gaussian of 4 / 2 = 2 pixels.
  auto impulse = torch::cat({torch::zeros({1, 3, size, size}), inside}, 1);
  impulse[0][0][32][32] = 1.0f;
  const auto spread = BlurWithinCoverage(impulse, batch, 4.0, resolution)[0][0];
  const double mass = spread.sum().item<double>();
  const double variance_px2 = ((x + 31.5f - 32.0f).square() * spread).sum().item<double>() / mass;
  EXPECT_NEAR(mass, 1.0, 1e-3);
  EXPECT_NEAR(std::sqrt(variance_px2), 2.0, 0.05);
  // Half the footprint (an image twice as large on the object): twice the pixels.
  Batch finer = batch;
  finer.uv_derivatives = batch.uv_derivatives * 0.5f;
  const auto wider = BlurWithinCoverage(impulse, finer, 4.0, resolution)[0][0];
  const double wider_variance = ((x + 31.5f - 32.0f).square() * wider).sum().item<double>() / wider.sum().item<double>();
  EXPECT_NEAR(std::sqrt(wider_variance), 4.0, 0.1);
  EXPECT_TRUE(torch::equal(BlurWithinCoverage(impulse, batch, 4.0, resolution).slice(1, 3, 4), inside));
}

// ChooseOutputBlur on held-out frames: none when the targets are as sharp as
// the renders, about the targets' own blur when they are blurred.
TEST(OutputBlurTest, ChoosesTheBlurOfTheHeldOutTargets) {
  std::vector<Batch> frames = Frames(3, 48, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  model_options.object_window_margin_px = 0;
  TrainOptions train_options;
  train_options.threads = 1;
  Trainer trainer(model_options, train_options);
  WarmStartCueRegression(trainer.model(), frames, train_options.cue_fit);
  std::vector<Batch> sharp, blurred;
  for (const Batch& frame : frames) {
    Batch target = frame;
    target.target_rgb = RenderFrameTensor(trainer.model(), frame).slice(1, 0, 3).clone();
    sharp.push_back(target);
    target.target_rgb = BlurWithinCoverage(RenderFrameTensor(trainer.model(), frame), frame, 1.0,
                                           model_options.texture_resolution_px).slice(1, 0, 3).clone();
    blurred.push_back(target);
  }
  const OutputBlurChoice none = ChooseOutputBlur(trainer.model(), sharp);
  EXPECT_EQ(none.chosen_texels, 0.0);
  EXPECT_EQ(none.tried.size(), OutputBlurCandidates().size());
  const OutputBlurChoice some = ChooseOutputBlur(trainer.model(), blurred);
  std::printf("output blur chosen for targets blurred by 1 texel: %.2f\n", some.chosen_texels);
  EXPECT_EQ(some.chosen_texels, 1.0);
  EXPECT_EQ(trainer.model()->output_blur_texels(), 1.0);
  // The same photos a pixel off (their frames' pose error): the renders
  // moved onto them first, the choice is the same, not a wider blur that
  // would absorb the shift.
  std::vector<Batch> shifted = blurred;
  for (Batch& frame : shifted) {
    frame.target_rgb = torch::roll(frame.target_rgb, {1}, {3});
    frame.target_matte = torch::roll(frame.target_matte, {1}, {3});
  }
  const OutputBlurChoice moved = ChooseOutputBlur(trainer.model(), shifted);
  std::printf("photos 1 px off: shift found %.2f px, output blur %.2f texels\n", moved.median_shift_px,
              moved.chosen_texels);
  for (const auto& [sigma, m] : moved.tried) std::printf("  %.2f texels: %.2f dB\n", sigma, m.psnr_db);
  for (const auto& [sigma, m] : some.tried) std::printf("  unshifted %.2f texels: %.2f dB\n", sigma, m.psnr_db);
  EXPECT_NEAR(moved.median_shift_px, 1.0, 0.2);  // phase correlation on 48-px frames reads 0.86
  EXPECT_EQ(moved.chosen_texels, 1.0);
}

// The one-standard-error rule: a narrower candidate whose excess over the
// best is within the noise of the frames is taken; one that is worse on
// every frame is not.
TEST(OutputBlurTest, TakesTheNarrowestWidthWithinOneStandardError) {
  const auto frame = [](double mse) {
    ImageMetrics m;
    m.mse = mse;
    m.foreground_pixels = 100;
    return m;
  };
  // Candidate 1 is the best pooled; 0 is worse on average but not on every frame.
  const std::vector<std::vector<ImageMetrics>> noisy = {
      {frame(1.10), frame(0.95), frame(1.12), frame(0.93)},
      {frame(1.00), frame(1.00), frame(1.00), frame(1.00)},
      {frame(1.20), frame(1.20), frame(1.20), frame(1.20)}};
  EXPECT_EQ(NarrowestWithinOneStandardError(noisy), 0u);
  // Candidate 0 worse by 5 % on every frame: beyond its (zero) standard error.
  const std::vector<std::vector<ImageMetrics>> consistent = {
      {frame(1.05), frame(1.05), frame(1.05), frame(1.05)},
      {frame(1.00), frame(1.00), frame(1.00), frame(1.00)},
      {frame(1.20), frame(1.20), frame(1.20), frame(1.20)}};
  EXPECT_EQ(NarrowestWithinOneStandardError(consistent), 1u);
  // Never wider than the best: candidate 2 ties 1 but comes after it.
  const std::vector<std::vector<ImageMetrics>> tie = {
      {frame(2.0), frame(2.0)}, {frame(1.0), frame(1.0)}, {frame(1.0), frame(1.0)}};
  EXPECT_EQ(NarrowestWithinOneStandardError(tie), 1u);
}

// The chosen blur travels with the checkpoint; older checkpoints render unblurred.
TEST(CheckpointTest, KeepsTheOutputBlurAndOlderOnesHaveNone) {
  TempDir dir;
  std::vector<Batch> frames = Frames(2, 32, 21);
  ModelOptions model_options = testing::TinyModelOptions();
  model_options.max_radiance = MaxRadiance(frames);
  Trainer trainer(model_options, TrainOptions());
  trainer.model()->set_output_blur_texels(0.75);
  const fs::path checkpoint = dir.path() / "checkpoint";
  SaveCheckpoint(checkpoint, trainer);
  EXPECT_EQ(LoadModel(checkpoint)->output_blur_texels(), 0.75);
  EXPECT_EQ(LoadTrainer(checkpoint)->model()->output_blur_texels(), 0.75);
  const fs::path info_path = checkpoint / "checkpoint.json";
  nlohmann::json info = nlohmann::json::parse(std::ifstream(info_path));
  info.erase("output_blur_texels");
  info["model_options"].erase("output_blur_texels");
  std::ofstream(info_path) << info.dump(2);
  EXPECT_EQ(LoadModel(checkpoint)->output_blur_texels(), 0.0);
}

TEST(CheckpointTest, OptionsRoundTripThroughYaml) {
  ModelOptions model_options;
  model_options.ngf = 48;
  model_options.variant = "dnl";
  model_options.object_window_margin_px = 0;
  model_options.upsampling = "resize_conv";
  model_options.max_radiance = 12.5;
  model_options.device = "auto";
  OptionsReader reader = OptionsReader::FromString(OptionsToJson(model_options).dump());
  ModelOptions read;
  ReadOptions(reader, &read);
  EXPECT_EQ(OptionsToJson(read), OptionsToJson(model_options));
  OptionsReader typo = OptionsReader::FromString("ngf: 16\nn_block: 3\n");
  ModelOptions model_read;
  EXPECT_THROW(ReadOptions(typo, &model_read), Error);
  OptionsReader bad_crop = OptionsReader::FromString("crop_px: 30\n");
  TrainOptions train_read;
  ReadOptions(bad_crop, &train_read);
  EXPECT_THROW(CheckOptions(train_read), Error);
  OptionsReader bad_variant = OptionsReader::FromString("variant: resnet\n");
  EXPECT_THROW(ReadOptions(bad_variant, &model_read), Error);
  EXPECT_THROW(ResolveDevice("tpu"), Error);
  if (!torch::cuda::is_available()) {
    EXPECT_THROW(ResolveDevice("cuda"), Error);
    EXPECT_EQ(ResolveDevice("auto"), torch::Device(torch::kCPU));
  }
}

}  // namespace
}  // namespace relit::relight
