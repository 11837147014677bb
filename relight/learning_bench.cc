// relit-relight-learning-bench: held-out quality of the DNL model against the
// cues-only baseline on the ground-truth spot workspace (the one the stage
// test uses), for a given model size and training budget.
//
//   relit-relight-learning-bench [--dir /tmp/relit_learning_bench] [--frames 24]
//       [--width 160] [--steps 300] [--ngf 16] [--blocks 3] [--texture 128]
//       [--channels 4] [--crop 96] [--lr 2e-4] [--texture-lr 2e-2] [--skip 1]
//       [--norm instance] [--init-spread 0.5] [--seed 5] [--dump DIR]
//
// The workspace (frames, cues, plan) is built once in --dir and reused.
// Prints the target statistics, M, and held-out PSNR / MAE of: the untrained
// model, the trained model and the cues-only baseline.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "core/image.h"
#include "core/main_wrapper.h"
#include "core/run_record.h"
#include "relight/checkpoint.h"
#include "relight/cue_frames.h"
#include "relight/cue_stage.h"
#include "relight/cues_baseline.h"
#include "relight/cue_texture_fit.h"
#include "relight/dataset.h"
#include "relight/metrics.h"
#include "relight/plan.h"
#include "relight/train_stage.h"
#include "relight/test_stages.h"
#include "relight/test_workspace.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;

void PrepareWorkspace(const std::string& dir, int frames, int width_px, bool support_plane, int target_spp,
                      int cue_spp, double proxy_offset_m) {
  if (fs::exists(fs::path(dir) / "relight/plan/plan.json")) return;
  testing::TestWorkspaceOptions o;
  o.frames = frames;
  o.width_px = width_px;
  o.samples_per_pixel = target_spp;
  o.proxy_offset_m = proxy_offset_m;
  testing::MakeTestWorkspace(dir, o);
  RunRecord record("bench");
  CueStageOptions cues;
  cues.samples_per_pixel = cue_spp;
  if (support_plane) {  // the synthetic scene's board and table (its wood's diffuse part)
    cues.support_plane = true;
    cues.table_albedo = {0.22, 0.14, 0.08};
  }
  testing::RunCuesAndSinglePartitionPlan(dir, cues, record);
}

int Run(int argc, char** argv) {
  CLI::App app{"held-out quality of the DNL model vs the cues-only baseline"};
  std::string dir = (fs::temp_directory_path() / "relit_learning_bench").string();
  int frames = 24, width = 160, steps = 300;
  ModelOptions model = testing::SmallModel();
  TrainStageOptions training;
  training.checkpoint_every = 1000000;
  training.validate_every = 0;
  training.log_every = 50;
  training.optimizer.crop_px = 96;
  training.optimizer.seed = 5;
  app.add_option("--dir", dir);
  app.add_option("--frames", frames);
  app.add_option("--width", width);
  app.add_option("--steps", steps);
  app.add_option("--variant", model.variant, "residual | dnl");
  app.add_option("--window-margin", model.object_window_margin_px, "object window margin (0 = random crops)");
  app.add_option("--ngf", model.ngf);
  app.add_option("--blocks", model.n_blocks);
  app.add_option("--texture", model.texture_resolution_px);
  app.add_option("--channels", model.channels_per_basis);
  app.add_option("--upsampling", model.upsampling);
  app.add_option("--norm", model.norm);
  app.add_option("--skip", model.input_skip);
  app.add_option("--init-spread", model.texture_init_spread);
  app.add_option("--texture-lr", training.optimizer.texture_learning_rate);
  app.add_option("--regression-lr", training.optimizer.regression_learning_rate);
  app.add_option("--crop", training.optimizer.crop_px);
  app.add_option("--lr", training.optimizer.learning_rate);
  app.add_option("--seed", training.optimizer.seed);
  bool support_plane = false;
  double proxy_offset_m = 0.002;
  app.add_option("--proxy-offset-m", proxy_offset_m, "GT mesh inflated by this much as the proxy (new --dir)");
  int target_spp = 16, cue_spp = 8;
  app.add_option("--target-spp", target_spp, "path-traced samples of the target frames (new --dir)");
  app.add_option("--cue-spp", cue_spp, "samples of the cue frames (new --dir)");
  app.add_flag("--support-plane", support_plane, "cues with the board and table as context geometry (new --dir)");
  CueFitOptions fit_options;
  int fit_resolution = 0;
  bool fit_only = false;
  app.add_option("--fit-resolution", fit_resolution, "smooth cue fit texture (0 = --texture)");
  app.add_option("--fit-diffuse", fit_options.smoothness_diffuse, "smooth cue fit: Lambert smoothness");
  app.add_option("--fit-specular", fit_options.smoothness_specular, "smooth cue fit: GGX smoothness");
  app.add_option("--fit-iterations", fit_options.iterations_per_level, "smooth cue fit: CG iterations per level");
  app.add_option("--fit-levels", fit_options.coarse_levels, "smooth cue fit: coarse levels");
  app.add_flag("--fit-only", fit_only, "score the cue fits only (no training)");
  std::string dump;
  app.add_option("--dump", dump, "write target / model / baseline EXRs of the held-out frames here");
  CLI11_PARSE(app, argc, argv);
  training.steps = steps;

  PrepareWorkspace(dir, frames, width, support_plane, target_spp, cue_spp, proxy_offset_m);
  const Plan plan = ReadPlan(dir + "/relight/plan/plan.json");
  std::vector<float> values;
  for (const PlanFrame& f : plan.frames) {
    const Image image = ReadImage(dir + "/" + f.image), matte = ReadImage(dir + "/" + f.matte);
    for (int y = 0; y < image.height(); ++y)
      for (int x = 0; x < image.width(); ++x)
        if (matte.at(x, y, 0) >= 0.5f) values.push_back(image.at(x, y, 1));
  }
  std::sort(values.begin(), values.end());
  auto q = [&](double p) { return values[static_cast<size_t>(p * (values.size() - 1))]; };
  std::printf("targets (green, foreground): median %.4f  p90 %.4f  p99 %.4f  max %.4f   M = %.4f\n", q(0.5),
              q(0.9), q(0.99), q(1.0), plan.max_radiance);

  {
    // The no-network fits: per-texel (cues-only baseline) and smooth bilinear.
    const int res = fit_resolution > 0 ? fit_resolution : model.texture_resolution_px;
    CuesOnlyBaseline per_texel(model.texture_resolution_px);
    CueTextureFit smooth(res, fit_options);
    for (int index : plan.partitions[0].train_frames) {
      const PlanFrame& f = plan.frames[index];
      const Image cues = ReadCueFrame(dir + "/" + f.cues), image = ReadImage(dir + "/" + f.image),
                  matte = ReadImage(dir + "/" + f.matte);
      per_texel.Accumulate(cues, image, matte);
      smooth.AddFrame(cues, image, matte);
    }
    per_texel.Solve();
    const auto fit_start = std::chrono::steady_clock::now();
    const CueFitStats stats = smooth.Solve();
    const double fit_s = SecondsSince(fit_start);
    auto score = [&](const std::vector<int>& frames, bool use_smooth) {
      std::vector<ImageMetrics> m;
      for (int index : frames) {
        const PlanFrame& f = plan.frames[index];
        const Image cues = ReadCueFrame(dir + "/" + f.cues);
        m.push_back(CompareToReference(use_smooth ? smooth.Predict(cues) : per_texel.Predict(cues),
                                       ReadImage(dir + "/" + f.image), ReadImage(dir + "/" + f.matte)));
      }
      return PoolMetrics(m).psnr_db;
    };
    if (!dump.empty()) {
      fs::create_directories(dump);
      for (int index : plan.partitions[0].validation_frames) {
        const PlanFrame& f = plan.frames[index];
        const Image cues = ReadCueFrame(dir + "/" + f.cues);
        const std::string stem = dump + "/" + fs::path(f.name).filename().string();
        WriteImage(stem + "_target.exr", ReadImage(dir + "/" + f.image));
        WriteImage(stem + "_smooth.exr", smooth.Predict(cues));
        WriteImage(stem + "_per_texel.exr", per_texel.Predict(cues));
      }
    }
    const auto& train = plan.partitions[0].train_frames;
    const auto& held = plan.partitions[0].validation_frames;
    std::printf("| fit | per-texel %d: train %.2f held-out %.2f dB | smooth %d (diffuse %.3g specular %.3g, %d it, "
                "%.1f s): train %.2f held-out %.2f dB |\n",
                model.texture_resolution_px, score(train, false), score(held, false), res,
                fit_options.smoothness_diffuse, fit_options.smoothness_specular, stats.iterations, fit_s,
                score(train, true), score(held, true));
    if (fit_only) return 0;
  }

  // Each run trains in its own copy, so runs may go in parallel.
  const std::string base = dir;
  dir = base + ".run" + std::to_string(::getpid());
  fs::remove_all(dir);
  fs::copy(base, dir, fs::copy_options::recursive);
  fs::remove_all(fs::path(dir) / "relight/partitions");
  const auto start = std::chrono::steady_clock::now();
  RunRecord record("bench");
  RunTrainStage(dir, 0, model, training, true, record);
  const double train_s = SecondsSince(start);

  CuesOnlyBaseline baseline(model.texture_resolution_px);
  testing::ForEachTrainFrame(dir, plan, [&](const Image& cues, const Image& image, const Image& matte) {
    baseline.Accumulate(cues, image, matte);
  });
  baseline.Solve();
  DnlModel trained = LoadModel(fs::path(dir) / "relight/partitions/00/checkpoint");
  std::vector<ImageMetrics> ours, theirs, train_fit;
  for (int index : plan.partitions[0].validation_frames) {
    const PlanFrame& f = plan.frames[index];
    const Image cues = ReadCueFrame(dir + "/" + f.cues);
    const Image target = ReadImage(dir + "/" + f.image), matte = ReadImage(dir + "/" + f.matte);
    const Batch batch = CueFrameToBatch(cues);
    const Image rendered = RenderFrame(trained, batch), predicted = baseline.Predict(cues);
    ours.push_back(CompareToReference(rendered, target, matte));
    theirs.push_back(CompareToReference(predicted, target, matte));
    if (!dump.empty()) {
      fs::create_directories(dump);
      WriteImage(dump + "/" + f.name + "_target.exr", target);
      WriteImage(dump + "/" + f.name + "_model.exr", rendered);
      WriteImage(dump + "/" + f.name + "_baseline.exr", predicted);
    }
  }
  for (int index : plan.partitions[0].train_frames) {
    const PlanFrame& f = plan.frames[index];
    const Image cues = ReadCueFrame(dir + "/" + f.cues);
    train_fit.push_back(CompareToReference(RenderFrame(trained, CueFrameToBatch(cues)),
                                           ReadImage(dir + "/" + f.image), ReadImage(dir + "/" + f.matte)));
  }
  const ImageMetrics a = PoolMetrics(ours), b = PoolMetrics(theirs), c = PoolMetrics(train_fit);
  std::printf("| %s win %d %s skip %d spread %.2f texlr %.0e ngf %d blocks %d tex %d C %d crop %d lr %.0e steps %d | train %.0f s | held-out PSNR %.2f dB "
              "MAE %.4f alpha %.4f | train-frame PSNR %.2f | cues-only %.2f dB MAE %.4f |\n",
              model.variant.c_str(), model.object_window_margin_px, model.norm.c_str(), model.input_skip ? 1 : 0, model.texture_init_spread, training.optimizer.texture_learning_rate, model.ngf, model.n_blocks, model.texture_resolution_px, model.channels_per_basis,
              training.optimizer.crop_px, training.optimizer.learning_rate, steps, train_s, a.psnr_db, a.mae,
              a.alpha_mae, c.psnr_db, b.psnr_db, b.mae);
  fs::remove_all(dir);
  return 0;
}

}  // namespace
}  // namespace relit::relight

int main(int argc, char** argv) {
  return relit::RunMain(argc, argv, relit::relight::Run);
}
