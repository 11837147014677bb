// The lock file W/relit.lock.json (schema relit.lock/1) and the rerun rules.
//
// Per step it records what the step's accepted output was made from: the
// SHA-256 of every input file or folder, of every upstream step's output, of
// the parameters it reads (and the parameters themselves, so `relit status`
// can say which one changed), of the tool executable, and of its own output.
// A step is up to date when all of these still match; anything else makes it
// stale, with the reasons listed. An entry is only marked "done" after the
// step's command exited 0; while it runs the entry says "running", so a run
// that is killed leaves "running" behind and the step reruns next time
// (its half-finished work is never accepted).
//
//   {"schema": "relit.lock/1",
//    "steps": {"calib": {"status": "done", "tool": {"path", "sha256"},
//                        "params": {...}, "params_sha256": "...",
//                        "inputs": {"step:capture": "<sha>", "inputs.view": "<sha>"},
//                        "output": {"path": "calib", "sha256": "..."},
//                        "finished_utc", "duration_s", "log", "command"},
//              "train-03": {"status": "failed", "exit_code": 1, "log", "message",
//                           "slurm_job": "1234_3"}, ...}}
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/hash.h"
#include "pipeline/steps.h"

namespace relit::pipeline {

class LockFile {
 public:
  static constexpr const char* kKind = "lock";
  static constexpr int kVersion = 1;

  // Loads W/relit.lock.json when it exists (an empty lock otherwise).
  explicit LockFile(std::string workspace);

  // The entry of a step, or null when it has none.
  const nlohmann::json* Entry(const std::string& step) const;
  void Set(const std::string& step, nlohmann::json entry);
  void Remove(const std::string& step);
  std::vector<std::string> StepNames() const;

  // The accepted output hash of a done step ("" otherwise).
  std::string OutputHash(const std::string& step) const;

  // Writes the file atomically.
  void Save() const;
  std::string path() const;

 private:
  std::string workspace_;
  nlohmann::json steps_ = nlohmann::json::object();
};

// What a step would be recorded with if it ran now, and why it is stale.
struct Evaluation {
  bool stale = false;
  std::vector<std::string> reasons;  // empty when up to date
  bool tool_missing = false;
  std::string tool_path, tool_sha256;
  nlohmann::json inputs = nlohmann::json::object();  // role -> sha256 (only when hashable)
  std::string params_sha256;
};

// Compares a step with its lock entry. `output_dir` is the absolute output
// folder. Upstream steps are compared through their recorded output hashes,
// so evaluate a step only after its upstream steps ran or were found up to
// date. `tool_path` "" means the tool was not found (`tool_searched` says
// where it was looked for).
Evaluation Evaluate(const Step& step, const LockFile& lock, HashCache& hashes,
                    const std::string& output_dir, const std::string& tool_path,
                    const std::string& tool_searched);

// The dotted keys whose values differ between two parameter objects, with
// old -> new values: "calib.detect.min_corners (12 -> 20)".
std::vector<std::string> ParameterChanges(const nlohmann::json& before, const nlohmann::json& now);

}  // namespace relit::pipeline
