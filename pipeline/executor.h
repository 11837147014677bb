// Executors run step commands: LocalExecutor as child processes of `relit`
// (a job pool; the runner decides how many at once), SlurmExecutor as sbatch
// jobs (one array job for steps submitted together, e.g. all training
// partitions) followed with squeue.
//
// Every job appends its stdout and stderr to its log file (the step's folder
// W/.relit/steps/<step>/log.txt), so a failure can always be read there.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "pipeline/config.h"

namespace relit::pipeline {

struct Job {
  std::string step;               // "train-03"
  std::string kind;               // "train"
  int array_index = -1;           // Slurm array index (partition), -1 = by position
  std::vector<std::string> argv;  // argv[0]: absolute executable path
  std::string step_dir;           // absolute W/.relit/steps/<step>
  std::string log_path;           // absolute
  std::string work_dir;           // the workspace
};

struct JobResult {
  std::string step;
  bool ok = false;
  int exit_code = 0;    // exit status; 128+N for signal N
  std::string message;  // why it failed (exit code, signal, Slurm state, job id)
  std::string job_id;   // Slurm "1234_3" or local pid
};

class Executor {
 public:
  virtual ~Executor() = default;
  // Starts the jobs (Slurm: as one array job when there are several).
  // Throws relit::Error when they cannot be started at all.
  virtual void Submit(const std::vector<Job>& jobs) = 0;
  // Jobs that ended since the last call.
  virtual std::vector<JobResult> Poll() = 0;
  // Stops every job still running (SIGTERM then SIGKILL / scancel).
  virtual void CancelAll() = 0;
  virtual size_t running() const = 0;
  // An id to show for a running step ("pid 1234", "slurm job 77_3").
  virtual std::string JobIdOf(const std::string& step) const = 0;
};

class LocalExecutor : public Executor {
 public:
  ~LocalExecutor() override;
  void Submit(const std::vector<Job>& jobs) override;
  std::vector<JobResult> Poll() override;
  void CancelAll() override;
  size_t running() const override { return running_.size(); }
  std::string JobIdOf(const std::string& step) const override;

 private:
  std::map<pid_t, std::string> running_;  // pid (also its process group) -> step
};

class SlurmExecutor : public Executor {
 public:
  // `slurm_dir`: W/.relit/slurm, for job scripts and Slurm's own output.
  SlurmExecutor(SlurmOptions options, std::string slurm_dir);
  ~SlurmExecutor() override;
  void Submit(const std::vector<Job>& jobs) override;
  std::vector<JobResult> Poll() override;
  void CancelAll() override;
  size_t running() const override { return tasks_.size(); }
  std::string JobIdOf(const std::string& step) const override;

  // The job script for `jobs` (exposed for tests and docs).
  static std::string JobScript(const std::vector<Job>& jobs, const std::vector<int>& indices);

 private:
  struct Task {
    std::string step;
    std::string job_id;  // "1234" or "1234_3"
    std::string step_dir, log_path, slurm_output;
  };
  JobResult Finished(const Task& task) const;

  SlurmOptions options_;
  std::string slurm_dir_;
  std::vector<Task> tasks_;
  std::chrono::steady_clock::time_point next_poll_{};
  int script_counter_ = 0;
};

// Runs a shell command, returns its exit status and stdout (stderr goes to
// `*err` when given, else is discarded).
int RunCapture(const std::string& command, std::string* out, std::string* err = nullptr);

// Where RunCapture keeps a command's stderr while it runs: a mkstemp
// template in $TMPDIR, or in /tmp when TMPDIR is unset or not a directory.
std::string CommandStderrTemplate();

}  // namespace relit::pipeline
