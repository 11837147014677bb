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

#include <string>

#include <nlohmann/json.hpp>

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

TrainStageResult RunTrainStage(const std::string& workspace, int partition, const ModelOptions& model,
                               const TrainStageOptions& train, bool restart, RunRecord& record);

}  // namespace relit::relight
