// For the relight tests and the learning bench: the stages they run on a
// test workspace (test_workspace.h), through the library and through the
// command line, and the training frames of its plan. Test-only code.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/run_record.h"
#include "relight/cue_stage.h"
#include "relight/plan.h"
#include "relight/relight_options.h"

namespace relit::relight::testing {

// relit-relight with `args` (args[0] is the program name), in this process;
// returns its exit code.
inline int RunCli(std::vector<std::string> args) {
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  return RunRelight(static_cast<int>(argv.size()), argv.data());
}

// A short training for the tests: `steps` steps on 2 threads, crops of
// `crop_px`, one checkpoint at the end and no validation before it.
inline TrainStageOptions ShortTraining(int steps, int crop_px) {
  TrainStageOptions train;
  train.steps = steps;
  train.checkpoint_every = steps;
  train.validate_every = 0;
  train.optimizer.crop_px = crop_px;
  train.optimizer.threads = 2;
  return train;
}

// The cue stage with `cues`, then the plan the tests train on: one
// partition, every fourth frame held out for validation.
inline void RunCuesAndSinglePartitionPlan(const std::string& dir, const CueStageOptions& cues, RunRecord& record) {
  RunCueStage(dir, cues, record);
  DatasetOptions dataset;
  dataset.holdout_every = 4;
  PartitionLayoutOptions layout;
  layout.layout = "single";
  RunPlanStage(dir, dataset, layout, record);
}

// `use(cues, image, matte)` for every training frame of the plan's first
// partition, read from the workspace `dir`, in the plan's order.
inline void ForEachTrainFrame(const std::string& dir, const Plan& plan,
                              const std::function<void(const Image&, const Image&, const Image&)>& use) {
  for (int index : plan.partitions[0].train_frames) {
    const PlanFrame& f = plan.frames[index];
    use(ReadCueFrame(dir + "/" + f.cues), ReadImage(dir + "/" + f.image), ReadImage(dir + "/" + f.matte));
  }
}

}  // namespace relit::relight::testing
