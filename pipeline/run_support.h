// Small pieces shared by `relit run` and `relit status`.
#pragma once

#include <string>

#include "pipeline/config.h"
#include "pipeline/steps.h"

namespace relit::pipeline {

// One `relit run` per workspace at a time: an exclusive flock on
// W/.relit/run.lock, held for the lifetime of this object (released by the
// kernel if the process dies, so a killed run never blocks the next one).
class WorkspaceRunLock {
 public:
  // Throws relit::Error when another run holds the lock.
  explicit WorkspaceRunLock(const std::string& workspace);
  ~WorkspaceRunLock();
  WorkspaceRunLock(const WorkspaceRunLock&) = delete;
  WorkspaceRunLock& operator=(const WorkspaceRunLock&) = delete;

  // Whether some process holds the lock of `workspace` now.
  static bool IsHeld(const std::string& workspace);

 private:
  int fd_ = -1;
};

// The last `lines` lines of a log file (progress redraws folded), "" if none.
std::string LogTail(const std::string& path, int lines);
// The last non-empty line of a log, shortened to ~100 characters.
std::string LastLogLine(const std::string& path);
// Prefixes every line of `text`.
std::string Indent(const std::string& text, const std::string& prefix);

// Whether the pipeline has an export step: run.export on/off, or for auto
// whether `relit-relight export --help` succeeds (the export subcommand is
// newer than the rest of the relight CLI).
bool WithExport(const PipelineConfig& config, const ToolLocator& tools);
// Augment steps: relight.augment.enabled (default true) and a relit-relight
// that has the augment subcommand.
bool WithAugment(const PipelineConfig& config, const ToolLocator& tools);
// Whether `relit-relight --help` lists the subcommand `name`.
bool RelightHasSubcommand(const ToolLocator& tools, const std::string& name);

}  // namespace relit::pipeline
