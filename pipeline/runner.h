// `relit run` and `relit status`: walks the step graph, decides per step
// whether it is up to date (lock.h), runs the stale ones (in parallel where
// the graph allows, up to run.jobs local steps; Slurm steps through sbatch),
// records accepted outputs in the lock file and shows the progress.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "pipeline/config.h"

namespace relit::pipeline {

struct RunOptions {
  std::string workspace;            // W (made absolute)
  std::vector<std::string> only;    // run just these steps (if stale)
  std::vector<std::string> from;    // rerun these and everything downstream
  std::vector<std::string> to;      // stop after these (and what they need)
  std::vector<std::string> force;   // run these even if up to date
  bool dry_run = false;             // print what would run and why
  int jobs = 0;                     // local steps at once; 0 = run.jobs
  std::string self_dir;             // where `relit` is (tool lookup); "" = /proc/self/exe
  double poll_interval_s = 0.2;     // local job polling
};

// Runs the pipeline; returns the process exit code (0 ok, 1 a step failed,
// 130 interrupted). Messages for the user go to `out`, failures to `err`
// (`out` when null); a live progress line is drawn on stderr when it is a
// terminal. A --only/--from/--to/--force selector that names no step of the
// pipeline, a --from/--to pair that selects nothing, a workspace path that
// is a file, and (dry run) a step that would be blocked are errors.
int RunPipeline(const PipelineConfig& config, const RunOptions& options, std::ostream& out,
                std::ostream* err = nullptr);

struct StepStatus {
  std::string name;
  std::string state;  // "up to date", "stale", "running", "failed", "not run yet", "waiting"
  std::vector<std::string> reasons;
  std::string log;    // log file path (absolute)
};

// The state of every step (train steps once plan.json exists).
std::vector<StepStatus> PipelineStatus(const PipelineConfig& config, const std::string& workspace,
                                       const std::string& self_dir = "");
void PrintStatus(const std::vector<StepStatus>& status, std::ostream& out);

}  // namespace relit::pipeline
