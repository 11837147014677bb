// Test helpers for the orchestrator: a temporary folder, and a set of small
// but real stage executables (bash scripts with the stages' command lines)
// that write deterministic outputs derived from their inputs and config, so
// the tests exercise the real runner, lock file and executors end to end in
// seconds. Every invocation is appended to a calls file.
//
// Script behaviour, controlled by environment variables (inherited by the
// steps, also through sbatch):
//   RELIT_TEST_CALLS        file that receives one line per invocation
//   RELIT_TEST_FAIL         step name that exits 3 (e.g. "calib", "train-01")
//   RELIT_TEST_SLEEP_S      seconds every train step sleeps (default 0)
//   RELIT_TEST_TRAIN_MARK   folder: train steps touch <folder>/train-KK.started
// plan writes as many partitions as the relight config's
// "dataset: {holdout_every: N}" (3): a real key, since relit run checks the
// whole relight: section.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace relit::pipeline::testing {

class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

void WriteText(const std::filesystem::path& path, const std::string& text);
std::string ReadText(const std::filesystem::path& path);

// Writes the stage scripts (relit-capture, relit-calib, relit-reconstruct,
// relit-relight, relit-report) into `bin_dir`.
void WriteStageScripts(const std::filesystem::path& bin_dir);

// A capture folder with view.mp4 and light.mp4 (arbitrary bytes) and a
// pipeline.yaml pointing at them and at the scripts in `bin_dir` via tools:.
// `extra` is appended to the YAML.
std::filesystem::path WriteScriptPipeline(const std::filesystem::path& dir,
                                          const std::filesystem::path& bin_dir,
                                          const std::string& extra = "");

// The lines of the calls file (each "tool args..."), and just the step names
// derived from them ("capture", "train-01", ...).
std::vector<std::string> CalledSteps(const std::filesystem::path& calls_file);

}  // namespace relit::pipeline::testing
