#include "relight/train_stage.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/options.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "relight/checkpoint.h"
#include "relight/cues_baseline.h"
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/metrics.h"
#include "relight/plan.h"
#include "relight/train_loop.h"
#include "relight/warm_start.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;





std::string PartitionDirName(int partition) {
  char name[16];
  std::snprintf(name, sizeof(name), "%02d", partition);
  return name;
}

namespace {

// One hash of cues.json and every cue frame it lists (tens of MB: well under
// a second).
std::string HashCueFrames(const fs::path& root, const std::string& cues_path, const CuesFile& cues) {
  uint64_t hash = HashFile(cues_path);
  for (const CueFrameRecord& frame : cues.frames) hash = hash * 1099511628211ull ^ HashFile((root / frame.file).string());
  return std::to_string(hash);
}

}  // namespace

std::unique_ptr<CueTextureFit> ReadWarmStartCueFit(const std::string& workspace, const CueFitOptions& fit,
                                                   int resolution_px, std::string* why_not) {
  auto refuse = [&](const std::string& reason) {
    *why_not = reason;
    return std::unique_ptr<CueTextureFit>();
  };
  const fs::path root(workspace);
  const std::string plan_path = (root / "relight" / "plan" / "plan.json").string();
  const Plan plan = ReadPlan(plan_path);
  if (plan.partitions.size() != 1) return refuse("the plan has more than one partition");
  std::vector<int> fitted;
  for (int i = 0; i < static_cast<int>(plan.frames.size()); ++i) {
    if (!plan.frames[i].validation) fitted.push_back(i);
  }
  std::vector<int> trained = plan.partitions[0].train_frames;
  std::sort(trained.begin(), trained.end());
  if (trained != fitted) return refuse("partition 00 does not train on every non-validation frame");
  const fs::path dir = root / "relight" / "partitions" / PartitionDirName(0);
  const fs::path fingerprint_path = dir / "fingerprint.json";
  if (!fs::exists(dir / "train.json") || !fs::exists(fingerprint_path) || !fs::exists(dir / "checkpoint")) {
    return refuse("partition 00 is not trained");
  }
  std::ifstream in(fingerprint_path);
  const json fingerprint = json::parse(in, nullptr, false);
  if (!fingerprint.is_object()) return refuse(fingerprint_path.string() + " is not a JSON object");
  const std::string cues_path = (root / "relight" / "cues" / "cues.json").string();
  if (fingerprint.value("plan", json()) != json(HashFile(plan_path)) ||
      fingerprint.value("cues", json()) != json(HashCueFrames(root, cues_path, ReadCuesFile(cues_path)))) {
    return refuse("partition 00 was trained on another plan or other cue frames");
  }
  const CheckpointInfo info = ReadCheckpointInfo(dir / "checkpoint");
  const ModelOptions& model = info.model_options;
  const TrainOptions& train = info.train_options;
  if (!model.residual() || model.cue_fit != "smooth") return refuse("the model did not start from the smooth cue fit");
  if (model.texture_resolution_px != resolution_px) return refuse("the model's texture has another resolution");
  if (train.regression_learning_rate > 0) return refuse("training moved the cue regression");
  if (OptionsToJson(train.cue_fit) != OptionsToJson(fit)) return refuse("train's cue_fit options differ");
  const bool same_mattes = train.matte_threshold == 0 || (train.matte_threshold == 0.5 && fit.align_rounds == 0);
  if (!same_mattes) return refuse("train's matte_threshold changes which pixels the fit reads");
  const torch::Tensor regression = LoadModel(dir / "checkpoint", "cpu")->regression().detach().to(torch::kFloat);
  const int64_t r = resolution_px, count = CueTextureFit::kWeights;
  RELIT_REQUIRE(regression.dim() == 4 && regression.size(1) == count && regression.size(2) == r &&
                    regression.size(3) == r,
                (dir / "checkpoint").string(), ": the cue regression is not ", count, " x ", r, " x ", r);
  // [1, k * 3 + c, y, x] -> [y][x][k * 3 + c], as the warm start wrote it.
  const torch::Tensor texels = regression[0].permute({1, 2, 0}).contiguous();
  std::vector<float> weights(texels.data_ptr<float>(), texels.data_ptr<float>() + texels.numel());
  auto reused = std::make_unique<CueTextureFit>(resolution_px, fit);
  reused->SetWeights(std::move(weights));
  return reused;
}

TrainStageResult RunTrainStage(const std::string& workspace, int partition, const ModelOptions& model_options_in,
                               const TrainStageOptions& options, bool restart, RunRecord& record) {
  CheckOptions(options, "train");
  const fs::path root(workspace);
  const std::string plan_path = (root / "relight" / "plan" / "plan.json").string();
  const Plan plan = ReadPlan(plan_path);
  record.AddInput("plan", plan_path);
  RELIT_REQUIRE(partition >= 0 && partition < static_cast<int>(plan.partitions.size()), "partition ", partition,
                " does not exist: the plan (", plan_path, ") has partitions 0..", plan.partitions.size() - 1);
  const PlanPartition& part = plan.partitions[partition];
  // Before anything is removed: a refused run leaves the trained partition alone.
  const std::string cues_path = (root / "relight" / "cues" / "cues.json").string();
  const CuesFile cues = ReadCuesFile(cues_path);
  const CueFormat rendered = cues.format;
  RELIT_REQUIRE(rendered == model_options_in.format, cues_path, ": the cue frames hold ", rendered.Describe(),
                " but the config asks for ", model_options_in.format.Describe(),
                ": rerun `relit-relight cues` and `plan` with this config");
  const fs::path dir = root / "relight" / "partitions" / PartitionDirName(partition);
  const fs::path checkpoint_dir = dir / "checkpoint", log_path = dir / "log.jsonl";
  const fs::path done_path = dir / "train.json";
  if (restart) fs::remove_all(dir);
  fs::create_directories(dir);
  fs::remove(done_path);  // from here on the partition is not trained until the end
  TrainStageResult result;
  if (part.train_frames.empty()) {
    result.skipped = true;
    record.Set("partition", partition);
    record.Set("skipped", "no training frame views the object from this partition's directions");
    record.Write(done_path.string());
    spdlog::warn("train: partition {} has no training frames: skipped", partition);
    return result;
  }

  ModelOptions model_options = model_options_in;
  model_options.max_radiance = plan.max_radiance;
  // Everything that changes the trajectory; `steps` and the cadences do not.
  // The cue frames count too: a new proxy (or calibration) renders new cues
  // under the same plan, and a checkpoint trained on the old ones is stale.
  const json fingerprint = {{"model", OptionsToJson(model_options)},
                            {"optimizer", OptionsToJson(options.optimizer)},
                            {"plan", HashFile(plan_path)},
                            {"cues", HashCueFrames(root, cues_path, cues)}};
  const fs::path fingerprint_path = dir / "fingerprint.json";
  std::unique_ptr<Trainer> trainer;
  bool fresh = false;
  if (fs::exists(checkpoint_dir / "checkpoint.json") && fs::exists(fingerprint_path)) {
    std::ifstream in(fingerprint_path);
    const json previous = json::parse(in, nullptr, false);
    if (!previous.is_discarded() && previous == fingerprint) {
      trainer = LoadTrainer(checkpoint_dir, model_options.device);
      result.resumed_from = trainer->step();
      spdlog::info("train: partition {} continues from its checkpoint at step {}", partition, trainer->step());
    } else {
      spdlog::info("train: partition {}: options or plan changed since the checkpoint: starting over", partition);
    }
  }
  if (!trainer) {
    fs::remove_all(checkpoint_dir);
    fs::remove(log_path);
    AtomicWriteFile(fingerprint_path, fingerprint.dump(2));
    trainer = std::make_unique<Trainer>(model_options, options.optimizer);
    fresh = true;
  } else {
    TruncateLog(log_path, trainer->step());
  }

  // Data: every training frame of the partition in memory (CPU tensors).
  std::vector<Batch> frames, validation;
  {
    auto timer = record.Time("load_frames");
    Progress progress("load frames", static_cast<int64_t>(part.train_frames.size()));
    for (int index : part.train_frames) {
      frames.push_back(LoadPlanFrame(workspace, plan.frames[index], model_options.format));
      progress.Advance();
    }
    progress.Finish();
    ThresholdMattes(frames, options.optimizer.matte_threshold);
    validation = LoadValidationFrames(workspace, plan, part, options.max_validation_frames, model_options.format,
                                      options.optimizer.matte_threshold);
  }

  // Clipped video pixels: one-sided in the warm start and in the loss.
  CueFitOptions cue_fit = options.optimizer.cue_fit;
  cue_fit.saturation_level = ResolveSaturationLevel(cue_fit.saturation_level, CaptureTransfer(workspace));
  trainer->set_saturation_level(cue_fit.saturation_level);
  record.Set("saturation_level", cue_fit.saturation_level);
  if (fresh && model_options.residual()) {
    auto timer = record.Time("warm_start");
    const WarmStartResult start = WarmStartCueRegression(trainer->model(), frames, cue_fit);
    json fit = model_options.cue_fit == "smooth"
                   ? start.stats.ToJson()
                   : json{{"pixels", start.stats.pixels},
                          {"texels_seen", start.stats.texels_seen},
                          {"ridge", CuesOnlyBaseline::kDefaultRidge}};
    fit["cue_fit"] = model_options.cue_fit;
    fit["texels"] = start.texels;
    record.Set("warm_start", fit);
    spdlog::info("train: partition {}: {} cue regression fitted on {} pixels ({} of {} texels seen)", partition,
                 model_options.cue_fit, start.stats.pixels, start.stats.texels_seen, start.texels);
    // The loss bounds clipped targets where the fit lifted them: at the
    // readings alone the network would pull the lifted texels back down.
    if (model_options.cue_fit == "smooth") {
      trainer->set_clip_overshoot(start.stats.clip_overshoot);
      trainer->set_clip_noise(start.stats.clip_noise);
    }
  } else if (fresh && cue_fit.clip_overshoot >= 1) {
    trainer->set_clip_overshoot(cue_fit.clip_overshoot);
  }
  record.Set("clip_overshoot", trainer->clip_overshoot());
  record.Set("clip_noise", trainer->clip_noise());

  FrameOrder order(static_cast<int>(frames.size()), options.optimizer.seed);
  TrainLoopSettings settings;
  settings.label = "train partition " + PartitionDirName(partition);
  settings.total_steps = options.steps;
  settings.checkpoint_every = options.checkpoint_every;
  settings.validate_every = options.validate_every;
  settings.log_every = options.log_every;
  settings.checkpoint_dir = checkpoint_dir;
  settings.log_path = log_path;
  const auto start = std::chrono::steady_clock::now();
  TrainLoopResult loop;
  {
    auto timer = record.Time("train");
    const int batch_size = options.optimizer.batch_size;
    loop = RunTrainLoop(*trainer, [&](int64_t step) {
      std::vector<const Batch*> batch;
      for (int b = 0; b < batch_size; ++b) batch.push_back(&frames[order.At(step * batch_size + b)]);
      return Concatenate(batch);
    }, validation, settings);
  }
  result.steps = trainer->step();
  result.final_loss = loop.final_loss;
  result.val_psnr_db = loop.validation.psnr_db;
  result.val_mae = loop.validation.mae;
  if (!loop.interrupted && options.validate_corrections && model_options.residual() && !validation.empty()) {
    const CorrectionChoice choice = KeepHelpfulCorrections(trainer->model(), validation);
    if (!choice.renderer_kept || !choice.mask_kept) SaveCheckpoint(checkpoint_dir, *trainer);
    record.Set("corrections", choice.ToJson());
    result.val_psnr_db = choice.chosen.psnr_db;
    result.val_mae = choice.chosen.mae;
    spdlog::info("train: partition {}: renderer correction {} (validation PSNR {:.2f} dB with, {:.2f} without), "
                 "mask correction {} (alpha MAE {:.4f} with, {:.4f} without)",
                 partition, choice.renderer_kept ? "kept" : "off", choice.trained.psnr_db,
                 choice.without_renderer.psnr_db, choice.mask_kept ? "kept" : "off", choice.trained.alpha_mae,
                 choice.without_mask.alpha_mae);
  }
  if (!loop.interrupted && model_options.residual() &&
      model_options.output_blur_texels == ModelOptions::kAutoOutputBlur) {
    if (validation.empty()) {
      spdlog::warn("train: partition {} has no held-out frames (dataset.holdout_every 0): no output blur chosen",
                   partition);
    } else {
      const double before = trainer->model()->output_blur_texels();
      const OutputBlurChoice blur = ChooseOutputBlur(trainer->model(), validation);
      if (blur.chosen_texels != before) SaveCheckpoint(checkpoint_dir, *trainer);
      record.Set("output_blur", blur.ToJson());
      // The choice compared renders moved onto their photos; the stage's
      // validation figure stays the model's own, as the user renders it.
      result.val_psnr_db = blur.unmoved.psnr_db;
      result.val_mae = blur.unmoved.mae;
      spdlog::info("train: partition {}: output blur {:.2f} texels (validation PSNR {:.2f} dB; with the frames "
                   "moved onto their renders by {:.2f} px median, {:.2f} dB against {:.2f} without the blur)",
                   partition, blur.chosen_texels, result.val_psnr_db, blur.median_shift_px, blur.moved.psnr_db,
                   blur.tried.front().second.psnr_db);
    }
  }
  if (loop.interrupted) {
    result.interrupted = true;
    spdlog::warn("train: partition {} stopped by signal {} at step {}; checkpoint saved, rerun to continue",
                 partition, loop.signal, result.steps);
    return result;
  }
  const double seconds = SecondsSince(start);
  record.Set("partition", partition);
  record.Set("steps", result.steps);
  record.Set("resumed_from_step", result.resumed_from);
  record.Set("training_frames", static_cast<int>(frames.size()));
  record.Set("validation_frames", static_cast<int>(validation.size()));
  record.Set("final_loss", result.final_loss);
  record.Set("max_radiance", plan.max_radiance);
  if (!validation.empty()) {
    record.Set("val_psnr_db", result.val_psnr_db);
    record.Set("val_mae", result.val_mae);
  }
  const int64_t trained = result.steps - result.resumed_from;
  record.Set("seconds_per_step", trained > 0 ? seconds / trained : 0.0);
  // The training budget in CPU time (all threads of this process, frame
  // loading included); a resumed run counts only its own part.
  record.Set("process_cpu_s", ProcessCpuSeconds());
  record.Set("resumed", result.resumed_from > 0);
  record.Set("input", model_options.format.ToJson());
  record.Write(done_path.string());
  spdlog::info("train: partition {} done: {} steps, loss {:.4f}{}", partition, result.steps, result.final_loss,
               validation.empty() ? std::string() : fmt::format(", validation PSNR {:.2f} dB", result.val_psnr_db));
  return result;
}

}  // namespace relit::relight
