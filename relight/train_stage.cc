#include "relight/train_stage.h"

#include <atomic>
#include <csignal>
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
#include "relight/cue_stage.h"
#include "relight/dataset.h"
#include "relight/metrics.h"
#include "relight/plan.h"

namespace relit::relight {

namespace fs = std::filesystem;
using nlohmann::json;

void TrainStageOptions::Read(OptionsReader& reader) {
  reader.ReadRange("steps", &steps, 1, 100000000);
  reader.ReadRange("checkpoint_every", &checkpoint_every, 1, 100000000);
  reader.ReadRange("validate_every", &validate_every, 0, 100000000);
  reader.ReadRange("log_every", &log_every, 1, 100000000);
  reader.ReadRange("max_validation_frames", &max_validation_frames, 0, 1000);
  optimizer.Read(reader);  // the optimiser's keys sit at the same level; it calls Finish()
  Check();
}

void TrainStageOptions::Check() const {
  RELIT_REQUIRE(steps >= 1, "train.steps must be >= 1");
  RELIT_REQUIRE(checkpoint_every >= 1 && log_every >= 1, "train.checkpoint_every and train.log_every must be >= 1");
  RELIT_REQUIRE(validate_every >= 0 && max_validation_frames >= 0,
                "train.validate_every and train.max_validation_frames must be >= 0");
  optimizer.Check();
}

json TrainStageOptions::ToJson() const {
  json j = optimizer.ToJson();
  j["steps"] = steps;
  j["checkpoint_every"] = checkpoint_every;
  j["validate_every"] = validate_every;
  j["log_every"] = log_every;
  j["max_validation_frames"] = max_validation_frames;
  return j;
}

std::string PartitionDirName(int partition) {
  char name[16];
  std::snprintf(name, sizeof(name), "%02d", partition);
  return name;
}

namespace {

std::atomic<int> g_signal{0};
extern "C" void OnStopSignal(int signal) { g_signal.store(signal); }

// Installs SIGINT/SIGTERM handlers for the scope (training checkpoints and
// stops cleanly instead of dying mid-step).
class StopSignals {
 public:
  StopSignals() {
    g_signal.store(0);
    previous_int_ = std::signal(SIGINT, OnStopSignal);
    previous_term_ = std::signal(SIGTERM, OnStopSignal);
  }
  ~StopSignals() {
    std::signal(SIGINT, previous_int_);
    std::signal(SIGTERM, previous_term_);
  }
  int received() const { return g_signal.load(); }

 private:
  void (*previous_int_)(int);
  void (*previous_term_)(int);
};

// Frame order: a fresh permutation per epoch, a pure function of (seed,
// epoch), so a resumed run visits the same frames as an uninterrupted one.
class FrameOrder {
 public:
  FrameOrder(int count, uint64_t seed) : count_(count), seed_(seed) {}
  int At(int64_t step) {
    const int64_t epoch = step / count_;
    if (epoch != epoch_) {
      auto generator = at::make_generator<at::CPUGeneratorImpl>(seed_ * 7919 + static_cast<uint64_t>(epoch) + 1);
      permutation_ = torch::randperm(count_, generator, torch::kLong);
      epoch_ = epoch;
    }
    return static_cast<int>(permutation_[step % count_].item<int64_t>());
  }

 private:
  int count_;
  uint64_t seed_;
  int64_t epoch_ = -1;
  torch::Tensor permutation_;
};

Batch Concatenate(const std::vector<const Batch*>& frames) {
  if (frames.size() == 1) return *frames[0];
  auto cat = [&](auto member) {
    std::vector<torch::Tensor> parts;
    for (const Batch* b : frames) parts.push_back(b->*member);
    return torch::cat(parts, 0);
  };
  Batch batch;
  batch.uv = cat(&Batch::uv);
  batch.uv_derivatives = cat(&Batch::uv_derivatives);
  batch.coverage = cat(&Batch::coverage);
  batch.cues = cat(&Batch::cues);
  batch.target_rgb = cat(&Batch::target_rgb);
  batch.target_matte = cat(&Batch::target_matte);
  return batch;
}

ImageMetrics Validate(DnlModel& model, const std::vector<Batch>& frames) {
  std::vector<ImageMetrics> metrics;
  for (const Batch& frame : frames) {
    const Image predicted = RenderFrame(model, frame);
    const Image target = TensorToImage(frame.target_rgb, {"R", "G", "B"});
    const Image matte = TensorToImage(frame.target_matte, {"A"});
    metrics.push_back(CompareToReference(predicted, target, matte));
  }
  return PoolMetrics(metrics);
}

// Keeps the log lines of steps <= `step` (the checkpoint a resumed run starts from).
void TruncateLog(const fs::path& log, int64_t step) {
  if (!fs::exists(log)) return;
  std::ifstream in(log);
  std::ostringstream kept;
  std::string line;
  while (std::getline(in, line)) {
    const json j = json::parse(line, nullptr, false);
    if (!j.is_discarded() && j.contains("step") && j["step"].get<int64_t>() <= step) kept << line << "\n";
  }
  AtomicWriteFile(log, kept.str());
}

}  // namespace

TrainStageResult RunTrainStage(const std::string& workspace, int partition, const ModelOptions& model_options_in,
                               const TrainStageOptions& options, bool restart, RunRecord& record) {
  options.Check();
  const fs::path root(workspace);
  const std::string plan_path = (root / "relight" / "plan" / "plan.json").string();
  const Plan plan = ReadPlan(plan_path);
  record.AddInput("plan", plan_path);
  RELIT_REQUIRE(partition >= 0 && partition < static_cast<int>(plan.partitions.size()), "partition ", partition,
                " does not exist: the plan (", plan_path, ") has partitions 0..", plan.partitions.size() - 1);
  const PlanPartition& part = plan.partitions[partition];
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
  const json fingerprint = {{"model", model_options.ToJson()},
                            {"optimizer", options.optimizer.ToJson()},
                            {"plan", HashFile(plan_path)}};
  const fs::path fingerprint_path = dir / "fingerprint.json";
  std::unique_ptr<Trainer> trainer;
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
  } else {
    TruncateLog(log_path, trainer->step());
  }

  // Data: every training frame of the partition in memory (CPU tensors).
  std::vector<Batch> frames, validation;
  {
    auto timer = record.Time("load_frames");
    Progress progress("load frames", static_cast<int64_t>(part.train_frames.size()));
    for (int index : part.train_frames) {
      frames.push_back(LoadPlanFrame(workspace, plan.frames[index]));
      progress.Advance();
    }
    progress.Finish();
    const int count = std::min<int>(options.max_validation_frames, static_cast<int>(part.validation_frames.size()));
    for (int i = 0; i < count; ++i) {
      const size_t pick = part.validation_frames.size() * (2 * i + 1) / (2 * count);  // evenly spread
      validation.push_back(LoadPlanFrame(workspace, plan.frames[part.validation_frames[pick]]));
    }
  }

  std::ofstream log(log_path, std::ios::app);
  FrameOrder order(static_cast<int>(frames.size()), options.optimizer.seed);
  StopSignals signals;
  const int64_t start_step = trainer->step();
  const int64_t total = options.steps;
  Progress progress("train partition " + PartitionDirName(partition), total - std::min(start_step, total));
  const auto start = std::chrono::steady_clock::now();
  double loss_sum = 0;
  int loss_count = 0;
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  auto validate = [&](int64_t step) {
    if (validation.empty()) return;
    const ImageMetrics m = Validate(trainer->model(), validation);
    result.val_psnr_db = m.psnr_db;
    result.val_mae = m.mae;
    log << json{{"step", step}, {"val_psnr_db", m.psnr_db}, {"val_mae", m.mae}, {"val_alpha_mae", m.alpha_mae}}.dump()
        << "\n" << std::flush;
  };
  {
    auto timer = record.Time("train");
    while (trainer->step() < total) {
      std::vector<const Batch*> batch;
      for (int b = 0; b < options.optimizer.batch_size; ++b) {
        batch.push_back(&frames[order.At(trainer->step() * options.optimizer.batch_size + b)]);
      }
      const Losses losses = trainer->Step(Concatenate(batch));
      const int64_t step = trainer->step();
      const double loss = losses.total.item<double>();
      RELIT_REQUIRE(std::isfinite(loss), "train: partition ", partition, ": the loss became ", loss, " at step ",
                    step, "; lower train.learning_rate or check the input frames");
      loss_sum += loss;
      ++loss_count;
      result.final_loss = loss;
      if (step % options.log_every == 0 || step == total) {
        log << json{{"step", step}, {"time_s", elapsed()}, {"loss", loss_sum / loss_count},
                    {"rgb_loss", losses.rgb.item<double>()}, {"mask_loss", losses.mask.item<double>()}}.dump()
            << "\n" << std::flush;
        char status[64];
        std::snprintf(status, sizeof(status), "loss %.4f", loss_sum / loss_count);
        progress.SetStatus(status);
        loss_sum = 0;
        loss_count = 0;
      }
      if (options.validate_every > 0 && step % options.validate_every == 0 && step != total) validate(step);
      progress.Advance();
      if (step % options.checkpoint_every == 0 || step == total || signals.received() != 0) {
        SaveCheckpoint(checkpoint_dir, *trainer);
      }
      if (signals.received() != 0) {
        result.interrupted = true;
        break;
      }
    }
  }
  progress.Finish();
  result.steps = trainer->step();
  if (result.interrupted) {
    spdlog::warn("train: partition {} stopped by signal {} at step {}; checkpoint saved, rerun to continue",
                 partition, signals.received(), result.steps);
    return result;
  }
  {
    auto timer = record.Time("validate");
    validate(result.steps);
  }
  const double seconds = elapsed();
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
  record.Write(done_path.string());
  spdlog::info("train: partition {} done: {} steps, loss {:.4f}{}", partition, result.steps, result.final_loss,
               validation.empty() ? std::string() : fmt::format(", validation PSNR {:.2f} dB", result.val_psnr_db));
  return result;
}

}  // namespace relit::relight
