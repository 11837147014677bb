// The scaffolding of one stage run that writes one output folder: the folder
// is written aside and appears only at Commit() (AtomicDir, with the output
// guard of docs/refusals.md), the run's messages go to a log file inside it,
// and the run record is written into it as run.json at Commit().
//
//   StageRun run({"relit-reconstruct", workspace / "reconstruct", options.force, {options.mesh},
//                 "--workspace", "reconstruct.log", level});
//   run.record().SetOptions(OptionsToJson(options));
//   Proxy proxy = run.Step("cleanup", [&] { return CleanupMesh(...); });
//   WriteObj((run.path() / "proxy.obj").string(), ...);
//   run.record().Set("faces", faces);
//   run.Commit();   // run.json, log closed, folder moved into place
//
// An exception before Commit() leaves the previous output untouched: the
// log file is closed first, then the temporary folder is removed.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <spdlog/spdlog.h>

#include "core/atomic_output.h"
#include "core/log.h"
#include "core/option_fields.h"
#include "core/run_record.h"

namespace relit {

struct StageRunSettings {
  std::string tool;                           // "relit-calib": the record's tool and the guard's stage
  std::filesystem::path target;               // the output folder, e.g. W/calib
  bool force = false;                         // the stage's --force
  std::vector<std::filesystem::path> inputs;  // never replaced, not even with force
  std::string option = "--out";               // the flag that chose `target`, for messages
  std::string log_file;                       // name inside the folder ("calib.log"); "" = none
  spdlog::level::level_enum level = spdlog::level::info;
};

class StageRun {
 public:
  // A guarded output folder with its own run record (and log file).
  explicit StageRun(const StageRunSettings& settings);
  // An output folder whose record belongs to the caller (relit-relight's
  // subcommands share one record per command line, and log elsewhere); the
  // record is written as `record_file`.
  StageRun(AtomicDir out, RunRecord& record, std::string record_file = "run.json");
  StageRun(const StageRun&) = delete;
  StageRun& operator=(const StageRun&) = delete;

  // Where to write until Commit(); where the folder appears after it.
  const std::filesystem::path& path() const { return out_.path(); }
  const std::filesystem::path& target() const { return out_.target(); }
  RunRecord& record() { return *record_; }

  // Runs `step` and adds its wall time to the record's timings_s[name].
  template <class F>
  decltype(auto) Step(const std::string& name, F&& step) {
    auto timer = record_->Time(name);
    return step();
  }

  // Writes the record (run.json), closes the log file (so the folder can
  // move) and moves the folder into place.
  void Commit();

 private:
  AtomicDir out_;
  std::optional<LogFileScope> log_;  // after out_: closed before the folder is removed
  std::optional<RunRecord> own_record_;
  RunRecord* record_;
  std::string record_file_ = "run.json";
};

// The end of a stage's command line: --force and --log-level go on top of
// the options, the log level is set, the options are checked, the stage
// runs (`run(options)`). Returns the exit code.
template <typename S, typename Run>
int RunStageCommand(S options, bool force, const std::string& log_level, Run run) {
  options.force = force;
  if (!log_level.empty()) options.log_level = log_level;
  SetVerbosity(ParseLogLevel(options.log_level));
  CheckOptions(options);
  run(options);
  return 0;
}

}  // namespace relit
