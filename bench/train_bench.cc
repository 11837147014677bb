// relit-bench-train: what the training data pipeline costs, and how much
// memory a training step takes.
//
// 1. Pipeline overhead: seconds per step of the real training loop
//    (relight::RunTrainStage on a generated workspace: frames read from the
//    workspace's cue EXRs, targets and mattes, frame order, random crops,
//    batching, logging, then forward + backward + Adam) against the bare
//    Trainer::Step on a pre-built, contiguous batch of the same crop size.
//    Steady state: both exclude the first kWarmupSteps steps; the loop's
//    per-step time comes from the time_s of its own log.jsonl. Real and bare
//    runs alternate, so machine load hits both alike. One-off costs (loading
//    the frames, a checkpoint, a validation) are reported separately and
//    amortised over the stage's default cadences.
// 2. Peak memory: peak resident memory (VmHWM) of one training step at the
//    CPU default size and at DNL's size (ngf 64, 9 blocks, 512 x 512 crop),
//    each in a fresh child process (this executable with --probe), and of a
//    whole short training run of the real loop.
// A benchmark, not a test. Results: docs/benchmarks.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "core/error.h"
#include "core/main_wrapper.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "relight/checkpoint.h"
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/plan.h"
#include "relight/test_scene.h"
#include "relight/test_workspace.h"
#include "relight/train_stage.h"

namespace relit::bench {
namespace {

namespace fs = std::filesystem;
using relight::Batch;

constexpr int kWarmupSteps = 10;  // = the loop's log_every: its first log line ends the warm-up

struct Options {
  std::string dir = (fs::temp_directory_path() / "relit_train_bench").string();
  int frames = 24;
  int width = 320;
  int steps = 60;  // timed steps per run, after the warm-up; a multiple of 10
  int repeats = 3;
  int threads = 2;
  bool memory = true;
  bool dnl = true;
  std::string probe;  // internal: "NGF,BLOCKS,CROP" or "loop"
};

// A small workspace as the stage test uses: ground-truth calib/reconstruct,
// then the real cue and plan stages (one partition).
void PrepareWorkspace(const Options& o) {
  if (fs::exists(fs::path(o.dir) / "relight/plan/plan.json")) return;
  std::printf("building the workspace in %s (once) ...\n", o.dir.c_str());
  std::fflush(stdout);
  relight::testing::TestWorkspaceOptions w;
  w.frames = o.frames;
  w.width_px = o.width;
  relight::testing::MakeTestWorkspace(o.dir, w);
  RunRecord record("bench");
  relight::RunCueStage(o.dir, relight::CueStageOptions{}, record);
  relight::DatasetOptions dataset;
  relight::PartitionLayoutOptions layout;
  layout.layout = "single";
  relight::RunPlanStage(o.dir, dataset, layout, record);
}

relight::TrainStageOptions LoopOptions(const Options& o, int steps) {
  relight::TrainStageOptions t;  // the stage's defaults, except:
  t.steps = steps;
  t.checkpoint_every = 100000000;  // only the final one (after the last log line)
  t.validate_every = 0;            // only at the end (timed on its own)
  t.log_every = kWarmupSteps;
  t.optimizer.threads = o.threads;
  return t;
}

struct LoopRun {
  double seconds_per_step = 0;  // steady state, from log.jsonl
  nlohmann::json timings;       // the run record's timings_s
};

LoopRun RunRealLoop(const Options& o) {
  RunRecord record("bench");
  const int total = kWarmupSteps + o.steps;
  relight::RunTrainStage(o.dir, 0, relight::ModelOptions{}, LoopOptions(o, total), /*restart=*/true, record);
  LoopRun run;
  run.timings = record.ToJson()["timings_s"];
  std::ifstream log(fs::path(o.dir) / "relight/partitions/00/log.jsonl");
  std::string line;
  double t_warm = -1, t_end = -1;
  while (std::getline(log, line)) {
    const nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.contains("time_s")) continue;
    if (j["step"] == kWarmupSteps) t_warm = j["time_s"];
    if (j["step"] == total) t_end = j["time_s"];
  }
  RELIT_REQUIRE(t_warm >= 0 && t_end > t_warm, "train bench: log.jsonl lacks the steps ", kWarmupSteps, " and ",
                total);
  run.seconds_per_step = (t_end - t_warm) / o.steps;
  return run;
}

Batch Contiguous(const Batch& b) {
  auto c = [](const torch::Tensor& t) { return t.contiguous().clone(); };
  return {c(b.uv), c(b.uv_derivatives), c(b.coverage), c(b.cues), c(b.target_rgb), c(b.target_matte)};
}

// The bare step: the same model and optimiser on a pre-built batch of crop
// size (no crop, no frame choice, no batching, no logging).
// With crop_px > 0 the step crops `batch` itself (Trainer::Step's RandomCrop:
// strided views of the whole frame), which isolates the crop's cost.
double RunBare(const Options& o, const relight::ModelOptions& model, const Batch& batch,
               double* checkpoint_seconds, int crop_px = 0) {
  relight::TrainOptions train = LoopOptions(o, 1).optimizer;
  train.crop_px = crop_px;
  relight::Trainer trainer(model, train);
  for (int s = 0; s < kWarmupSteps; ++s) trainer.Step(batch).total.item<double>();
  const auto start = std::chrono::steady_clock::now();
  for (int s = 0; s < o.steps; ++s) trainer.Step(batch).total.item<double>();
  const double seconds = SecondsSince(start) / o.steps;
  if (checkpoint_seconds != nullptr) {
    const fs::path dir = fs::path(o.dir) / "bench_checkpoint";
    const auto ckpt_start = std::chrono::steady_clock::now();
    relight::SaveCheckpoint(dir, trainer);
    *checkpoint_seconds = SecondsSince(ckpt_start);
    fs::remove_all(dir);
  }
  return seconds;
}

// Child process: one training step, printing its peak resident memory.
int Probe(const Options& o) {
  if (o.probe == "loop") {
    RunRecord record("bench");
    relight::RunTrainStage(o.dir, 0, relight::ModelOptions{}, LoopOptions(o, kWarmupSteps), true, record);
    std::printf("RELIT_PROBE rss_before_mib=0 peak_mib=%.1f seconds=0 params=0\n", ProcStatusMiB("VmHWM"));
    return 0;
  }
  int ngf = 0, blocks = 0, crop = 0;
  RELIT_REQUIRE(std::sscanf(o.probe.c_str(), "%d,%d,%d", &ngf, &blocks, &crop) == 3, "--probe NGF,BLOCKS,CROP");
  relight::ModelOptions model;
  model.ngf = ngf;
  model.n_blocks = blocks;
  model.mask_ngf = std::max(1, ngf / 2);
  model.mask_n_blocks = blocks / 2;
  model.max_radiance = 2.0;
  relight::TrainOptions train;
  train.threads = o.threads;
  train.crop_px = 0;
  relight::Trainer trainer(model, train);
  int64_t params = 0;
  for (const auto& p : trainer.model()->parameters()) params += p.numel();
  const Batch b = relight::testing::RandomBatch(crop);
  const double before = ProcStatusMiB("VmRSS");
  RELIT_REQUIRE(ResetPeakRss(), "cannot reset the peak RSS (/proc/self/clear_refs)");
  const auto start = std::chrono::steady_clock::now();
  trainer.Step(b).total.item<double>();
  const double seconds = SecondsSince(start);
  std::printf("RELIT_PROBE rss_before_mib=%.1f peak_mib=%.1f seconds=%.2f params=%lld\n", before,
              ProcStatusMiB("VmHWM"), seconds, static_cast<long long>(params));
  return 0;
}

struct ProbeResult {
  double before = 0, peak = 0, seconds = 0;
  long long params = 0;
};

ProbeResult RunProbe(const Options& o, const std::string& what) {
  const std::string command = ShellQuote(fs::read_symlink("/proc/self/exe").string()) + " --probe " +
                              ShellQuote(what) + " --threads " + std::to_string(o.threads) + " --dir " +
                              ShellQuote(o.dir) + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  RELIT_REQUIRE(pipe != nullptr, "cannot run ", command);
  ProbeResult r;
  bool found = false;
  char line[4096];
  std::string output;
  while (fgets(line, sizeof(line), pipe) != nullptr) {
    output += line;
    found = found || std::sscanf(line, "RELIT_PROBE rss_before_mib=%lf peak_mib=%lf seconds=%lf params=%lld",
                                 &r.before, &r.peak, &r.seconds, &r.params) == 4;
  }
  const int status = pclose(pipe);
  RELIT_REQUIRE(found && status == 0, "memory probe '", what, "' failed:\n", output);
  return r;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

int Run(int argc, char** argv) {
  Options o;
  CLI::App app{"training data-pipeline overhead and peak memory per step"};
  app.add_option("--dir", o.dir, "workspace (built once, reused)");
  app.add_option("--frames", o.frames, "phone frames of the generated workspace");
  app.add_option("--width", o.width, "image width of the generated workspace, px");
  app.add_option("--steps", o.steps, "timed steps per run (after 10 warm-up steps)")->check(CLI::Range(10, 100000));
  app.add_option("--repeats", o.repeats, "real/bare run pairs")->check(CLI::Range(1, 100));
  app.add_option("--threads", o.threads, "torch threads")->check(CLI::Range(1, 1024));
  app.add_flag("!--no-memory", o.memory, "skip the peak-memory probes");
  app.add_flag("!--no-dnl", o.dnl, "skip the DNL-size memory probe (one step takes ~15-50 s)");
  app.add_option("--probe", o.probe, "internal: run one memory probe")->group("");
  CLI11_PARSE(app, argc, argv);
  if (!o.probe.empty()) return Probe(o);
  RELIT_REQUIRE(o.steps % kWarmupSteps == 0, "--steps must be a multiple of ", kWarmupSteps);

  PrepareWorkspace(o);
  const relight::Plan plan = relight::ReadPlan(o.dir + "/relight/plan/plan.json");
  const relight::PlanPartition& part = plan.partitions.at(0);
  const relight::ModelOptions defaults;
  const relight::TrainOptions train_defaults;
  relight::ModelOptions model = defaults;
  model.max_radiance = plan.max_radiance;
  const Batch frame = relight::LoadPlanFrame(o.dir, plan.frames.at(part.train_frames.at(0)));
  at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(1);
  const Batch crop = Contiguous(relight::RandomCrop(frame, train_defaults.crop_px, generator));

  std::printf("relit training pipeline benchmark, %s, load average %s\n", Today().c_str(), LoadAverage().c_str());
  std::printf("workspace %s: %zu training frames of %lldx%lld; model ngf %d, %d blocks, mask %d/%d, texture %d x %d "
              "x %d; crop %lld x %lld; %d torch threads\n",
              o.dir.c_str(), part.train_frames.size(), static_cast<long long>(frame.width()),
              static_cast<long long>(frame.height()), model.ngf, model.n_blocks, model.mask_ngf, model.mask_n_blocks,
              model.texture_resolution_px, model.texture_resolution_px, 5 * model.channels_per_basis,
              static_cast<long long>(crop.height()), static_cast<long long>(crop.width()), o.threads);
  std::fflush(stdout);

  std::printf("\n| pair | load avg | real loop s/step | bare step s/step | overhead | bare step + crop of one frame "
              "s/step | its overhead |\n|---|---|---|---|---|---|---|\n");
  std::vector<double> real, bare, ratio, cropped, cropped_ratio;
  LoopRun last;
  double checkpoint_seconds = 0;
  for (int r = 0; r < o.repeats; ++r) {
    const std::string load = LoadAverage();
    last = RunRealLoop(o);
    real.push_back(last.seconds_per_step);
    bare.push_back(RunBare(o, model, crop, r == 0 ? &checkpoint_seconds : nullptr));
    ratio.push_back(real.back() / bare.back() - 1.0);
    cropped.push_back(RunBare(o, model, frame, nullptr, train_defaults.crop_px));
    cropped_ratio.push_back(cropped.back() / bare.back() - 1.0);
    std::printf("| %d | %s | %.4f | %.4f | %+.1f%% | %.4f | %+.1f%% |\n", r + 1, load.c_str(), real.back(),
                bare.back(), 100 * ratio.back(), cropped.back(), 100 * cropped_ratio.back());
    std::fflush(stdout);
  }
  std::printf("| median | %s | %.4f | %.4f | %+.1f%% | %.4f | %+.1f%% |\n", LoadAverage().c_str(), Median(real),
              Median(bare), 100 * Median(ratio), Median(cropped), 100 * Median(cropped_ratio));

  // The loop's data work per step in isolation: a random crop (with the
  // matte test) of an in-memory frame.
  const int crops = 500;
  const auto crop_start = std::chrono::steady_clock::now();
  for (int i = 0; i < crops; ++i) relight::RandomCrop(frame, train_defaults.crop_px, generator);
  const double crop_seconds = SecondsSince(crop_start) / crops;

  const double load_s = last.timings.value("load_frames", 0.0), validate_s = last.timings.value("validate", 0.0);
  const relight::TrainStageOptions cadence;
  const double step = Median(bare);
  auto share = [&](double s) { return 100.0 * s / step; };
  std::printf("\nOne-off and per-step costs (last run), amortised over the stage defaults (steps %d, "
              "checkpoint_every %d, validate_every %d, %d validation frames):\n",
              cadence.steps, cadence.checkpoint_every, cadence.validate_every, cadence.max_validation_frames);
  std::printf("| cost | seconds | per step at defaults | %% of a bare step |\n|---|---|---|---|\n");
  std::printf("| RandomCrop of an in-memory frame (every step) | %.6f | %.6f | %.2f%% |\n", crop_seconds, crop_seconds,
              share(crop_seconds));
  std::printf("| load %zu training + %d validation frames (once) | %.3f | %.6f | %.2f%% |\n", part.train_frames.size(),
              std::min<int>(cadence.max_validation_frames, static_cast<int>(part.validation_frames.size())), load_s,
              load_s / cadence.steps, share(load_s / cadence.steps));
  std::printf("| checkpoint (every %d steps) | %.3f | %.6f | %.2f%% |\n", cadence.checkpoint_every,
              checkpoint_seconds, checkpoint_seconds / cadence.checkpoint_every,
              share(checkpoint_seconds / cadence.checkpoint_every));
  std::printf("| validation (every %d steps) | %.3f | %.6f | %.2f%% |\n", cadence.validate_every, validate_s,
              validate_s / cadence.validate_every, share(validate_s / cadence.validate_every));

  if (o.memory) {
    std::printf("\nPeak resident memory, each in a fresh process (VmHWM; 'step' = reset just before one step):\n");
    std::printf("| what | params (M) | RSS before step MiB | peak RSS MiB | peak - before MiB | step s |\n");
    std::printf("|---|---|---|---|---|---|\n");
    auto print = [&](const std::string& label, const ProbeResult& p) {
      std::printf("| %s | %.2f | %.1f | %.1f | %.1f | %.2f |\n", label.c_str(), p.params / 1e6, p.before, p.peak,
                  p.peak - p.before, p.seconds);
      std::fflush(stdout);
    };
    char config[64];
    std::snprintf(config, sizeof(config), "%d,%d,%d", defaults.ngf, defaults.n_blocks, train_defaults.crop_px);
    print(std::string("one step, CPU default (") + config + ")", RunProbe(o, config));
    if (o.dnl) print("one step, DNL size (64,9,512)", RunProbe(o, "64,9,512"));
    const ProbeResult loop = RunProbe(o, "loop");
    std::printf("| real loop, %d steps, all frames in memory (whole process) | - | - | %.1f | - | - |\n", kWarmupSteps,
                loop.peak);
  }
  std::printf("load average at the end: %s\n", LoadAverage().c_str());
  return 0;
}

}  // namespace
}  // namespace relit::bench

int main(int argc, char** argv) { return relit::RunMain(argc, argv, relit::bench::Run); }
