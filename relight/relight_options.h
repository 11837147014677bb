// The `relight:` section of pipeline.yaml (the file `relit-relight --config`
// reads). Top-level keys: cues, dataset, partitions, model, train, augment,
// render, export, eval, log_level. Unknown keys are errors. docs/relight.md explains every key.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "relight/eval.h"
#include "relight/interop.h"
#include "relight/learn_options.h"
#include "relight/partitions.h"
#include "relight/stage_options.h"

namespace relit::relight {

struct RelightOptions {
  std::string workspace;
  CueStageOptions cues;
  DatasetOptions dataset;
  PartitionLayoutOptions partitions;
  ModelOptions model;
  TrainStageOptions train;
  RenderStageOptions render;
  AugmentOptions augment;
  EvalOptions eval;        // `relit-relight eval` (eval.h)
  InteropOptions exports;  // key `export`: the interop exports next to the asset
  std::string log_level = "info";

  void Read(OptionsReader& reader);
  void Check() const;
  nlohmann::json ToJson() const;
};

// Reads a whole `relight:` section into default options and checks it (every
// key, to the last level), as relit-relight would; for `relit run`'s check
// of pipeline.yaml. No LibTorch.
void CheckRelightSection(OptionsReader& reader);

// `relit-relight <cues|plan|train|augment|render|export|eval|compare> ...`;
// see docs/relight.md.
int RunRelight(int argc, char** argv);

}  // namespace relit::relight
