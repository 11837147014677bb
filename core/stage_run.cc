#include "core/stage_run.h"

namespace relit {

StageRun::StageRun(const StageRunSettings& settings)
    : out_(settings.target, OutputGuard{settings.tool, settings.force, settings.inputs}, settings.option) {
  if (!settings.log_file.empty()) log_.emplace((out_.path() / settings.log_file).string(), settings.level);
  own_record_.emplace(settings.tool);
  record_ = &*own_record_;
}

StageRun::StageRun(AtomicDir out, RunRecord& record, std::string record_file)
    : out_(std::move(out)), record_(&record), record_file_(std::move(record_file)) {}

void StageRun::Commit() {
  record_->Write((out_.path() / record_file_).string());
  log_.reset();
  out_.Commit();
}

}  // namespace relit
