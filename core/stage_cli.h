// The command line every workspace stage (relit-calib, relit-reconstruct,
// relit-report) shares: --workspace and --config first, the stage's own
// flags, then --log-level and --force; the options file is read and the
// stage run through RunStageCommand (core/stage_run.h). Header-only: the
// stages' executables link CLI11, the core library does not.
#pragma once

#include <string>
#include <utility>

#include <CLI/CLI.hpp>

#include "core/option_fields.h"
#include "core/stage_run.h"

namespace relit {

struct StageCommandLine {
  // `stage` ("calib") names the folder W/calib and the options; `folders`
  // says what the stage reads and writes, for --workspace's help.
  StageCommandLine(std::string stage, std::string folders) : stage(std::move(stage)), folders(std::move(folders)) {}

  std::string stage, folders;
  std::string workspace, config, log_level;
  bool force = false;

  void AddWorkspaceAndConfig(CLI::App& app) {
    app.add_option("--workspace", workspace, "workspace folder W (" + folders + ")");
    app.add_option("--config", config, "YAML file with " + stage + " options (unknown keys are errors)")
        ->check(CLI::ExistingFile);
  }
  void AddLogLevelAndForce(CLI::App& app) {
    app.add_option("--log-level", log_level, "trace | debug | info | warn | error");
    app.add_flag("--force", force, "replace a W/" + stage + " folder that relit-" + stage + " did not write");
  }

  // The options file (defaults without --config), --workspace over its workspace.
  template <typename S>
  S ReadOptions() const {
    S options = ReadOptionsFile<S>(config);
    if (!workspace.empty()) options.workspace = workspace;
    return options;
  }

  template <typename S, typename Run>
  int RunStage(S options, Run run) const {
    return RunStageCommand(std::move(options), force, log_level, run);
  }
};

}  // namespace relit
