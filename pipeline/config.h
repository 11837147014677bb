// pipeline.yaml: the inputs of a capture, the board, the orchestrator's own
// settings and one section per stage (docs/pipeline.md documents every key).
//
//   inputs:      {view, light, geometry, board_view_images, board_light_images, proxy_mesh,
//                 truth (a synthetic capture's truth.json: adds the eval step)}
//   board:       the printed ChArUco board (core/board.h), given to calib
//   tools:       optional paths of the stage executables
//   run:         {jobs, executor: local | slurm, export: auto | on | off}
//   slurm:       sbatch resources and which steps go through Slurm
//   capture: calib: reconstruct: relight: report:   the stages' own options
//
// Reading checks everything before anything runs: unknown keys and wrong
// types anywhere (the stage sections are read with the stages' own option
// readers) are errors with pipeline.yaml's path, line and dotted key.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "core/option_fields.h"

namespace relit::pipeline {

// sbatch resources of one kind of step.
struct SlurmResources {
  std::string partition;               // --partition ("" = cluster default)
  std::string account;                 // --account ("" = none)
  int cpus = 2;                        // --cpus-per-task
  std::string memory = "8G";           // --mem
  int gpus = 0;                        // --gres=gpu:N when > 0
  std::string time = "04:00:00";       // --time
  std::vector<std::string> extra_args;  // appended to sbatch as given

  static const OptionFields<SlurmResources>& Fields();
};

struct SlurmOptions {
  // Step kinds submitted with sbatch (the others run on the submitting host).
  std::vector<std::string> steps = {"cues", "train"};
  double poll_s = 10;  // squeue polling interval
  std::string sbatch = "sbatch", squeue = "squeue", scontrol = "scontrol", sacct = "sacct",
              scancel = "scancel";
  SlurmResources defaults;                          // slurm.resources
  std::map<std::string, SlurmResources> per_kind;   // slurm.cues, slurm.train, ...: over `defaults`

  static const OptionFields<SlurmOptions>& Fields();  // per_kind is read by Read
  void Read(OptionsReader& reader);
  const SlurmResources& For(const std::string& kind) const;
};

// inputs: (absolute paths once loaded; "" = not given)
struct PipelineInputs {
  std::string view, light, geometry, board_view_images, board_light_images, proxy_mesh, truth;
  static const OptionFields<PipelineInputs>& Fields();
};

// run:
struct RunSettings {
  int jobs = 1;                      // local steps running at once
  std::string executor = "local";    // local | slurm
  std::string export_mode = "auto";  // YAML `export`: auto | on | off
  static const OptionFields<RunSettings>& Fields();
};

// The sections' members are reached directly (config.view, config.jobs).
struct PipelineConfig : PipelineInputs, RunSettings {
  std::string file;      // absolute path of pipeline.yaml
  std::string base_dir;  // its folder: relative paths are relative to it

  YAML::Node board;                          // board: (checked with ReadBoardSpec)
  std::map<std::string, std::string> tools;  // stage -> executable (absolute)

  SlurmOptions slurm;

  // The stage sections exactly as written (Null when absent).
  YAML::Node capture, calib, reconstruct, relight, report;

  // Reads and checks pipeline.yaml (see the file comment). Throws
  // relit::Error with file:line for any problem.
  static PipelineConfig Load(const std::string& path);
  static PipelineConfig FromString(const std::string& text, const std::string& file,
                                   const std::string& base_dir);
};

// The stage names with a `tools:` entry and their executable names.
const std::map<std::string, std::string>& StageExecutables();

// The commented template `relit init` writes.
std::string PipelineTemplate();

// YAML node -> JSON with every scalar as a string (YAML scalars are untyped;
// this is for hashing and for showing which parameter changed).
nlohmann::json YamlToJson(const YAML::Node& node);
// YAML text of a node (block style); "{}" for Null.
std::string YamlText(const YAML::Node& node);

namespace internal {
// Reads a stage section with that stage's own options reader, so typos and
// wrong types are caught before anything runs (stage_check.cc).
void CheckStageSections(const PipelineConfig& config, const YAML::Node& root);
}  // namespace internal

}  // namespace relit::pipeline
