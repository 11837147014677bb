// The steps of a pipeline run and how each one is invoked.
//
//   capture -> calib -> reconstruct -> cues -> plan -> train-KK (one per
//   partition, known once plan ran) -> render -> [export] -> report
//
// A step is an external command (a stage executable) with: the files it
// reads from outside the workspace (inputs: videos, board clips, a proxy
// mesh), the steps whose outputs it reads (deps), the folder it writes in the
// workspace (output), the parameters it reads (params, hashed for the rerun
// rules) and a per-step YAML config file relit writes for it.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/config.h"

namespace relit::pipeline {

struct StepInput {
  std::string role;  // "inputs.view"
  std::string path;  // absolute file or folder
};

struct Step {
  std::string name;  // "calib", "train-03"
  std::string kind;  // "calib", "train"
  int partition = -1;  // train steps
  std::vector<std::string> deps;
  std::vector<StepInput> inputs;
  std::string output;       // workspace-relative folder the step writes
  nlohmann::json params;    // what the step reads from pipeline.yaml
  std::string config_yaml;  // per-step config file content ("" = none)
  std::string tool;         // stage: "capture", "relight", ...
  // Arguments after the executable; "{config}" is replaced by the path of the
  // per-step config file.
  std::vector<std::string> args;
};

// The step kinds in pipeline order.
const std::vector<std::string>& StepKinds();

// Where the stage executables are. Looked up in this order, the first
// existing file wins:
//   1. tools.<stage> in pipeline.yaml
//   2. $RELIT_BIN_DIR/<exe>, then $RELIT_BIN_DIR/<stage folder>/<exe>
//   3. the build tree next to `relit`: <relit dir>/../<stage folder>/<exe>,
//      then <relit dir>/<exe> (an install with everything in one bin/)
//   4. PATH
class ToolLocator {
 public:
  ToolLocator(std::map<std::string, std::string> overrides, std::string self_dir);
  // Absolute path, or "" when not found.
  std::string Find(const std::string& stage) const;
  // Where Find() looked, for the "not found" message.
  std::string Searched(const std::string& stage) const;

 private:
  std::vector<std::string> Candidates(const std::string& stage) const;
  std::map<std::string, std::string> overrides_;
  std::string self_dir_;
};

// The folder of the running executable (from /proc/self/exe).
std::string SelfDirectory();

class StepGraph {
 public:
  // Every step except the per-partition train steps. `workspace` must be
  // absolute. `with_export` adds the export step, `with_augment` an augment
  // step per partition (after every train step).
  StepGraph(const PipelineConfig& config, const std::string& workspace, bool with_export,
            bool with_augment = false);

  // Adds train-KK for each partition index and makes render/export depend on
  // them. Replaces earlier train steps.
  void ExpandPartitions(const std::vector<int>& partitions);
  bool expanded() const { return expanded_; }

  // Steps in a topological order (pipeline order, partitions ascending).
  const std::vector<Step>& steps() const { return steps_; }
  const Step* Find(const std::string& name) const;
  // Names of steps that (transitively) depend on `name`.
  std::vector<std::string> Downstream(const std::string& name) const;
  std::vector<std::string> Upstream(const std::string& name) const;

 private:
  void Add(Step step);
  const PipelineConfig config_;
  const std::string workspace_;
  const bool with_augment_;
  std::vector<Step> steps_;
  bool expanded_ = false;
};

// Partition indices listed in W/relight/plan/plan.json (relit.relight_plan/1).
// Throws relit::Error when it is missing or invalid.
std::vector<int> ReadPlanPartitions(const std::string& workspace);

// Two-digit partition folder name: 3 -> "03".
std::string PartitionName(int index);

// True when `selector` names the step: its name, its kind ("train" for
// every partition) or "relight" for every relight sub-step.
bool SelectorMatches(const std::string& selector, const Step& step);
// Whether `selector` can match some step at all (for early errors).
bool IsKnownSelector(const std::string& selector);

}  // namespace relit::pipeline
