// The `relight:` section of pipeline.yaml (the file `relit-relight --config`
// reads). Top-level keys: cues, dataset, partitions, model, train, augment,
// render, export, eval, log_level. Unknown keys are errors. The field tables
// (relight_options.cc, stage_options.cc, cue_texture_fit.cc, partitions.cc)
// read, check and write them; docs/relight.md's tables are generated from
// them (tools/options_doc).
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

  // `workspace` is --workspace, not a key of the file (relit-relight checks
  // it); reading copies the cues' format into the model's.
  static const OptionFields<RelightOptions>& Fields();
};

// Reads a whole `relight:` section into default options and checks it (every
// key, to the last level, the workspace aside), as relit-relight does; for
// `relit run`'s check of pipeline.yaml and relit-relight --config. No LibTorch.
RelightOptions ReadRelightSection(OptionsReader& reader);
void CheckRelightSection(OptionsReader& reader);

// `relit-relight <cues|plan|train|augment|render|export|eval|compare> ...`;
// see docs/relight.md.
int RunRelight(int argc, char** argv);

}  // namespace relit::relight
