// `relit status`: the state of every step without running anything. A step
// is stale for its own reasons (lock.h) or because an upstream step is stale,
// running or failed (it would rerun first).
#include <algorithm>
#include <filesystem>
#include <map>

#include "pipeline/lock.h"
#include "pipeline/run_support.h"
#include "pipeline/runner.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

std::vector<StepStatus> PipelineStatus(const PipelineConfig& config, const std::string& workspace,
                                       const std::string& self_dir) {
  const std::string w = fs::absolute(workspace).lexically_normal().string();
  LockFile lock(w);
  // Hash-cache updates are kept: the next run profits from them.
  HashCache hashes((fs::path(w) / ".relit" / "hash_cache.json").string());
  ToolLocator tools(config.tools, self_dir.empty() ? SelfDirectory() : self_dir);
  StepGraph graph(config, w, WithExport(config, tools), WithAugment(config, tools));
  std::error_code error;
  const bool have_plan = fs::exists(fs::path(w) / "relight" / "plan" / "plan.json", error);
  if (have_plan) graph.ExpandPartitions(ReadPlanPartitions(w));
  const bool run_active = WorkspaceRunLock::IsHeld(w);

  std::vector<StepStatus> result;
  std::map<std::string, std::string> state_of;
  for (const Step& step : graph.steps()) {
    StepStatus s;
    s.name = step.name;
    s.log = (fs::path(w) / ".relit" / "steps" / step.name / "log.txt").string();
    const nlohmann::json* entry = lock.Entry(step.name);
    const std::string recorded = entry ? entry->value("status", "") : "";
    std::vector<std::string> blocked_by;
    for (const std::string& d : step.deps) {
      if (state_of[d] != "up to date") blocked_by.push_back(d);
    }
    if (recorded == "running" && run_active) {
      s.state = "running";
      const std::string line = LastLogLine(s.log);
      const std::string job = entry->value("job", std::string());
      s.reasons.push_back((job.empty() ? "" : job + ", ") + "since " +
                          entry->value("started_utc", std::string("?")) + (line.empty() ? "" : ": " + line));
    } else {
      const Evaluation e =
          Evaluate(step, lock, hashes, (fs::path(w) / step.output).string(), tools.Find(step.tool),
                   tools.Searched(step.tool));
      if (recorded == "failed") {
        s.state = "failed";
        s.reasons.push_back(entry->value("message", std::string("error")) +
                            (entry->contains("job") ? " (" + entry->value("job", std::string()) + ")" : ""));
      } else if (!entry) {
        s.state = "not run yet";
      } else if (!e.stale && blocked_by.empty()) {
        s.state = "up to date";
      } else {
        s.state = "stale";
      }
      if (!blocked_by.empty() && entry) {
        std::string text = "upstream ";
        for (size_t i = 0; i < blocked_by.size(); ++i) text += (i ? ", " : "") + blocked_by[i];
        s.reasons.push_back(text + " not up to date");
      }
      if (s.state == "stale" || s.state == "not run yet") {
        for (const std::string& r : e.reasons) {
          // "never run" and missing upstream outputs are said by the state.
          if (r == "never run" || r.rfind("upstream step ", 0) == 0) continue;
          s.reasons.push_back(r);
        }
      }
    }
    state_of[step.name] = s.state;
    result.push_back(s);
    if (step.kind == "plan" && !have_plan) {
      StepStatus train;
      train.name = "train-KK";
      train.state = "waiting";
      train.reasons.push_back("one step per partition, known after plan ran");
      state_of[train.name] = train.state;
      result.push_back(train);
    }
  }
  return result;
}

void PrintStatus(const std::vector<StepStatus>& status, std::ostream& out) {
  size_t width = 4;
  for (const StepStatus& s : status) width = std::max(width, s.name.size());
  int up_to_date = 0;
  for (const StepStatus& s : status) {
    out << "  " << s.name << std::string(width - s.name.size() + 2, ' ') << s.state;
    if (!s.reasons.empty()) out << ": " << s.reasons.front();
    out << "\n";
    for (size_t i = 1; i < s.reasons.size(); ++i) {
      out << "  " << std::string(width + 2, ' ') << "  " << s.reasons[i] << "\n";
    }
    if (s.state == "failed") out << "  " << std::string(width + 2, ' ') << "  log " << s.log << "\n";
    up_to_date += s.state == "up to date";
  }
  if (up_to_date == static_cast<int>(status.size())) {
    out << "everything is up to date\n";
  } else {
    out << up_to_date << " of " << status.size() << " steps up to date\n";
  }
}

}  // namespace relit::pipeline
