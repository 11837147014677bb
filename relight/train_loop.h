// The optimisation loop shared by `train` (point-light frames) and
// `augment` (fine-tuning on captured + augmented frames): steps, log lines,
// validation, checkpoints, and a clean stop on SIGINT/SIGTERM.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "relight/metrics.h"
#include "relight/model.h"

namespace relit::relight {

// Frame order: a fresh permutation per epoch, a pure function of (seed,
// epoch), so a resumed run visits the same frames as an uninterrupted one.
class FrameOrder {
 public:
  FrameOrder(int count, uint64_t seed) : count_(count), seed_(seed) {}
  int At(int64_t step);

 private:
  int count_;
  uint64_t seed_;
  int64_t epoch_ = -1;
  torch::Tensor permutation_;
};

// Frames of equal size stacked along the batch dimension.
Batch Concatenate(const std::vector<const Batch*>& frames);

// Whole-frame metrics of `model` on captured frames with targets, pooled;
// prediction and target clipped at the capture's white level first, as eval does
// (a few unclipped highlights far above it otherwise decide the figure:
// -0.1 dB on a frame that scores 14.6 clipped).
ImageMetrics Validate(DnlModel& model, const std::vector<Batch>& frames);

// The residual model's two corrections (model.h: renderer and mask networks
// behind gates) judged on held-out frames: the mask correction stays only
// if it lowers the alpha MAE, the renderer's only if it raises the PSNR;
// a correction that does not is switched off (its gate set to 0), so the
// model is never worse there than the cue regression and the proxy's
// coverage it starts from.
struct CorrectionChoice {
  bool renderer_kept = true, mask_kept = true;
  ImageMetrics trained;            // both corrections as trained
  ImageMetrics without_mask;       // mask gate 0
  ImageMetrics without_renderer;   // renderer gate 0 (mask as chosen)
  ImageMetrics chosen;
  nlohmann::json ToJson() const;
};
CorrectionChoice KeepHelpfulCorrections(DnlModel& model, const std::vector<Batch>& validation);

// The residual model's output blur (ModelOptions::output_blur_texels -1):
// each of OutputBlurCandidates() applied to the model's renders of the
// held-out frames; the narrowest width whose pooled MSE is within one
// standard error of the best one's is set on the model
// (NarrowestWithinOneStandardError). Each held-out render is first moved
// onto its photo by the shift phase correlation finds over the object (its
// calibrated pose's error, which new views do not have).
struct OutputBlurChoice {
  double chosen_texels = 0;
  double best_texels = 0;  // the best pooled score's width (chosen_texels is at most it)
  double median_shift_px = 0;  // of the held-out photos onto the renders
  std::vector<std::pair<double, ImageMetrics>> tried;  // width in texels, metrics on the moved frames
  ImageMetrics moved;    // the chosen width's, on the moved frames
  ImageMetrics unmoved;  // the chosen width's on the frames as they are (what Validate gives)
  nlohmann::json ToJson() const;
};
OutputBlurChoice ChooseOutputBlur(DnlModel& model, const std::vector<Batch>& validation);

// The one-standard-error rule of model selection (Breiman et al. 1984,
// Hastie et al. "Elements of Statistical Learning" 7.10): per_frame[c][f]
// scores candidate c (ordered from the simplest) on held-out frame f; the
// first candidate whose pooled MSE exceeds the best one's by no more than
// the standard error of that difference (paired over the frames). The
// held-out curve of the output blur is flat near its best, and a few
// dozen frames cannot tell those widths apart; the narrower one keeps
// the detail.
size_t NarrowestWithinOneStandardError(const std::vector<std::vector<ImageMetrics>>& per_frame);

// Keeps the log lines of steps <= `step` (the checkpoint a resumed run starts from).
void TruncateLog(const std::filesystem::path& log, int64_t step);

struct TrainLoopSettings {
  std::string label;                      // progress bar and messages
  int64_t total_steps = 0;                // train until trainer.step() == total_steps
  int checkpoint_every = 250;
  int validate_every = 0;                 // 0 = only at the end
  int log_every = 10;
  std::filesystem::path checkpoint_dir;
  std::filesystem::path log_path;         // appended to
};

struct TrainLoopResult {
  bool interrupted = false;
  int signal = 0;
  double final_loss = 0;
  ImageMetrics validation;                // at the end (zeros without validation frames)
};

// Runs `trainer` to settings.total_steps on the batches `next_batch(step)`
// gives (step = the trainer's step before the update). `tag(step)` may name
// the kind of batch in log lines ("" = no tag).
TrainLoopResult RunTrainLoop(Trainer& trainer, const std::function<Batch(int64_t)>& next_batch,
                             const std::vector<Batch>& validation, const TrainLoopSettings& settings,
                             const std::function<std::string(int64_t)>& tag = {});

}  // namespace relit::relight
