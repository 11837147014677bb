// Training checkpoints: everything needed to continue a run exactly.
//
// A checkpoint is a directory, written atomically (core/atomic_output.h: a
// temporary directory renamed into place), holding
//   model.pt         texture level 0 and both networks (torch::save of DnlModel)
//   optimizer.pt     Adam state (moments and step counts per parameter)
//   rng.pt           state of the trainer's crop generator
//   checkpoint.json  schema relit.checkpoint/1:
//                    {"step", "model_options", "train_options", "torch_version",
//                     "files": {...}}
// Resuming from it and training on the same batches reproduces the
// uninterrupted run bit for bit on the CPU (deterministic kernels, fixed
// thread count); see CheckpointTest in relight/train_test.cc.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "relight/model.h"

namespace relit::relight {

struct CheckpointInfo {
  static constexpr const char* kKind = "checkpoint";
  static constexpr int kVersion = 1;

  int64_t step = 0;
  double clip_overshoot = 1;  // the loss's lift of clipped targets (Trainer::set_clip_overshoot)
  double clip_noise = 0;      // the loss's censored model of clipped targets (Trainer::set_clip_noise); 0 before it
  double output_blur_texels = 0;  // Render's blur in use (DnlModelImpl::output_blur_texels); 0 before it
  ModelOptions model_options;
  TrainOptions train_options;
};

// Writes `trainer`'s state to the directory `dir`, replacing any previous
// checkpoint there atomically.
void SaveCheckpoint(const std::filesystem::path& dir, Trainer& trainer);

// Reads and validates checkpoint.json. Throws relit::Error naming the file.
CheckpointInfo ReadCheckpointInfo(const std::filesystem::path& dir);

// A trainer restored from `dir`, ready to continue. `device` overrides the
// stored model device when not empty ("cpu", "cuda", "auto").
std::unique_ptr<Trainer> LoadTrainer(const std::filesystem::path& dir, const std::string& device = "");

// Only the model (for rendering), on `device` (empty = the stored one).
DnlModel LoadModel(const std::filesystem::path& dir, const std::string& device = "");

// Throws relit::Error (naming the checkpoint and both settings) when the
// checkpoint in `dir` was trained on another light input than `configured`
// (cues.input / cues.bases): its networks would read the wrong channels.
void RequireCheckpointFormat(const std::filesystem::path& dir, const CueFormat& configured);

}  // namespace relit::relight
