// `relit-relight train --partition K`: trains one partition's neural
// texture and networks on its frames of W/relight/plan/plan.json.
//
// Output folder W/relight/partitions/KK/ (KK = two digits):
//   checkpoint/   latest checkpoint (checkpoint.h), every checkpoint_every
//                 steps, at the end and on SIGINT/SIGTERM
//   log.jsonl     {"step","time_s","loss","rgb_loss","mask_loss"} every
//                 log_every steps; {"step","val_psnr_db","val_mae",
//                 "val_alpha_mae"} at every validation
//   train.json    written last (relit.run/1): options, steps, final losses and
//                 validation; its presence means the partition is trained.
// A rerun continues from checkpoint/ when the model, optimiser and data
// options and the plan are unchanged (exactly: same crops and frame order),
// otherwise it starts over; --restart always starts over.
#pragma once

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "relight/cue_texture_fit.h"
#include "relight/model.h"
#include "relight/partitions.h"
#include "relight/learn_options.h"

namespace relit {
class OptionsReader;
class RunRecord;
}

namespace relit::relight {


struct TrainStageResult {
  bool skipped = false;          // the partition has no training frame
  int64_t steps = 0;
  int64_t resumed_from = 0;      // 0 = fresh start
  bool interrupted = false;      // stopped by a signal after checkpointing
  double final_loss = 0;
  double val_psnr_db = 0;        // 0 when there is no validation frame
  double val_mae = 0;
};

std::string PartitionDirName(int partition);  // "07"

// The smooth cue fit that partition 0's residual model started from (its
// cue-regression weights, read from the checkpoint), when that is exactly
// the fit `fit` at `resolution_px` would solve on the plan's training
// frames now: the plan has one partition holding every non-validation
// frame; train's fingerprint.json matches the plan and cue frames; the
// model is residual with model.cue_fit smooth at that texture resolution
// and train.regression_learning_rate 0; train's cue_fit options equal
// `fit`; the mattes the fit read agree (matte_threshold 0, or 0.5 without
// alignment: the fit keeps pixels at matte >= 0.5 either way). Otherwise
// null, with the first condition that failed in *why_not. Eval's cue_fit
// method then skips solving the same fit a second time.
std::unique_ptr<CueTextureFit> ReadWarmStartCueFit(const std::string& workspace, const CueFitOptions& fit,
                                                   int resolution_px, std::string* why_not);

TrainStageResult RunTrainStage(const std::string& workspace, int partition, const ModelOptions& model,
                               const TrainStageOptions& train, bool restart, RunRecord& record);

}  // namespace relit::relight
