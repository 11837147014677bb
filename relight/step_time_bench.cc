// relit-relight-step-bench: seconds per training step (forward + backward +
// Adam) of the DNL model for a few network sizes and crop sizes, on random
// inputs. Used to pick the CPU defaults (docs/relight.md).
//
//   relit-relight-step-bench [--threads 2] [--steps 3] [--device cpu]
//                            [--config NGF,BLOCKS,CROP ...] [--quality STEPS]
//
// Prints a Markdown table. Without --config, runs the built-in list. With
// --quality, each config also trains STEPS steps on the synthetic problem of
// relight/test_scene.h (8 frames of 64 x 64, lr 2e-3) and reports the
// log-space L1 on 4 held-out frames: a capacity proxy, not real-data quality.
#include <chrono>
#include <ctime>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/main_wrapper.h"
#include "core/run_record.h"
#include "relight/model.h"
#include "relight/test_scene.h"
#include "relight/test_scene.h"

namespace relit::relight {
namespace {

struct Config {
  int ngf, blocks, crop;
};

// Log-space L1 inside the matte on held-out frames after training.
double HeldOutError(const ModelOptions& base, int threads, int steps) {
  const auto material = testing::SyntheticMaterial(41);
  std::vector<Batch> train, test;
  for (int f = 0; f < 12; ++f) (f < 8 ? train : test).push_back(testing::SyntheticFrame(material, 64, f, 42));
  ModelOptions model_options = base;
  model_options.max_radiance = 0;
  for (const auto& b : train) model_options.max_radiance = std::max(model_options.max_radiance, b.target_rgb.max().item<double>());
  TrainOptions train_options;
  train_options.threads = threads;
  train_options.crop_px = 0;
  train_options.learning_rate = 2e-3;
  Trainer trainer(model_options, train_options);
  for (int s = 0; s < steps; ++s) trainer.Step(train[s % train.size()]);
  torch::NoGradGuard no_grad;
  double error = 0;
  for (const auto& b : test) {
    const ModelOutput out = trainer.model()->Forward(b);
    error += trainer.model()->Loss(out, b).rgb.item<double>() / test.size();
  }
  return error;
}

int Run(int argc, char** argv) {
  CLI::App app("Times DNL training steps for several model sizes.");
  int threads = 2, steps = 3, texture_px = 256, quality_steps = 0;
  std::string device = "cpu";
  std::vector<std::string> config_texts;
  app.add_option("--threads", threads, "torch intra-op threads");
  app.add_option("--steps", steps, "timed steps per config (after one warm-up step)");
  app.add_option("--device", device, "cpu, cuda or auto");
  app.add_option("--texture", texture_px, "neural texture resolution, px");
  app.add_option("--quality", quality_steps, "also train this many steps on the synthetic problem");
  app.add_option("--config", config_texts, "NGF,BLOCKS,CROP (mask net: NGF/2, BLOCKS/2)");
  CLI11_PARSE(app, argc, argv);
  std::vector<Config> configs = {{8, 2, 128}, {16, 3, 128}, {16, 6, 256}, {32, 6, 128},
                                 {32, 6, 256}, {32, 9, 256}, {64, 9, 256}};
  if (!config_texts.empty()) {
    configs.clear();
    for (const auto& text : config_texts) {
      Config c{};
      if (std::sscanf(text.c_str(), "%d,%d,%d", &c.ngf, &c.blocks, &c.crop) != 3) {
        throw Error("--config expects NGF,BLOCKS,CROP, got '" + text + "'");
      }
      configs.push_back(c);
    }
  }
  std::printf("| ngf | blocks | mask ngf/blocks | crop px | params (M) | wall s/step | CPU s/step | steps | held-out L1 |\n");
  std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
  for (const Config& c : configs) {
    ModelOptions model_options;
    model_options.ngf = c.ngf;
    model_options.n_blocks = c.blocks;
    model_options.mask_ngf = std::max(1, c.ngf / 2);
    model_options.mask_n_blocks = c.blocks / 2;
    model_options.max_radiance = 2.0;
    model_options.texture_resolution_px = texture_px;
    model_options.device = device;
    TrainOptions train_options;
    train_options.threads = threads;
    train_options.crop_px = 0;
    Trainer trainer(model_options, train_options);
    int64_t params = 0;
    for (const auto& p : trainer.model()->parameters()) params += p.numel();
    const Batch batch = testing::RandomBatch(c.crop);
    trainer.Step(batch);  // warm-up (allocations, kernel selection)
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    for (int s = 0; s < steps; ++s) trainer.Step(batch).total.item<double>();
    const double seconds = SecondsSince(start) / steps;
    const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC / steps;
    std::string quality = "-";
    if (quality_steps > 0) {
      char text[32];
      std::snprintf(text, sizeof(text), "%.4f", HeldOutError(model_options, threads, quality_steps));
      quality = text;
    }
    std::printf("| %d | %d | %d/%d | %d | %.2f | %.3f | %.3f | %d | %s |\n", c.ngf, c.blocks, model_options.mask_ngf,
                model_options.mask_n_blocks, c.crop, params / 1e6, seconds, cpu_seconds, steps, quality.c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace relit::relight

int main(int argc, char** argv) {
  return relit::RunMain(argc, argv, relit::relight::Run);
}
