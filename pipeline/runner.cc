#include "pipeline/runner.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <thread>

#include "core/atomic_output.h"
#include "core/error.h"
#include "core/progress.h"
#include "core/run_record.h"
#include "core/shell.h"
#include "pipeline/executor.h"
#include "pipeline/lock.h"
#include "pipeline/run_support.h"
#include "pipeline/selection.h"

namespace relit::pipeline {

namespace fs = std::filesystem;

namespace {

std::atomic<int> g_signal{0};
extern "C" void OnSignal(int signal) { g_signal = signal; }

enum class State { kPending, kRunning, kDone, kUpToDate, kSkipped, kFailed, kBlocked, kWouldRun };

bool Settled(State s) { return s != State::kPending && s != State::kRunning; }

std::string Join(const std::vector<std::string>& parts, const std::string& separator) {
  std::string text;
  for (const std::string& p : parts) text += (text.empty() ? "" : separator) + p;
  return text;
}

class Runner {
 public:
  Runner(const PipelineConfig& config, const RunOptions& options, std::ostream& out, std::ostream& err)
      : config_(config),
        options_(options),
        w_(options.workspace),
        out_(out),
        err_(err),
        selection_(options.only, options.from, options.to, options.force),
        lock_(w_),
        hashes_((fs::path(w_) / ".relit" / "hash_cache.json").string()),
        tools_(config.tools, options.self_dir.empty() ? SelfDirectory() : options.self_dir),
        graph_(config, w_, WithExport(config, tools_), WithAugment(config, tools_)),
        jobs_(options.jobs > 0 ? options.jobs : config.jobs) {
    for (const Step& s : graph_.steps()) states_[s.name] = State::kPending;
    if (config.executor == "slurm") {
      slurm_ = std::make_unique<SlurmExecutor>(config.slurm, (fs::path(w_) / ".relit" / "slurm").string());
    }
  }

  int Run();

 private:
  bool OnSlurm(const Step& step) const {
    return slurm_ && std::find(config_.slurm.steps.begin(), config_.slurm.steps.end(), step.kind) !=
                         config_.slurm.steps.end();
  }
  std::string StepDir(const Step& s) const { return (fs::path(w_) / ".relit" / "steps" / s.name).string(); }
  std::string LogPath(const Step& s) const { return StepDir(s) + "/log.txt"; }
  std::string OutputDir(const Step& s) const { return (fs::path(w_) / s.output).string(); }
  std::string Ordinal(const Step& s) const;
  void Preflight();
  void CheckSelectors(bool final_check) const;
  bool Schedule(std::map<std::string, std::vector<Job>>* slurm_batches);
  void MaybeExpand();
  Job Prepare(const Step& step, const Evaluation& e);
  void Complete(const JobResult& result);
  void ShowProgress(bool force);
  void WriteRunRecord(int code);
  // Notes the pid / Slurm job of a running step in its lock entry (for status).
  void RecordJobId(const std::string& step, const std::string& job) {
    const nlohmann::json* entry = lock_.Entry(step);
    if (!entry) return;
    nlohmann::json updated = *entry;
    updated["job"] = job;
    lock_.Set(step, updated);
    lock_.Save();
  }
  int Finish(int code);

  const PipelineConfig& config_;
  const RunOptions& options_;
  const std::string w_;
  std::ostream& out_;
  std::ostream& err_;
  Selection selection_;
  LockFile lock_;
  HashCache hashes_;
  ToolLocator tools_;
  StepGraph graph_;
  const int jobs_;
  LocalExecutor local_;
  std::unique_ptr<SlurmExecutor> slurm_;
  std::map<std::string, State> states_;
  std::map<std::string, Evaluation> evaluations_;  // of running steps
  std::map<std::string, std::chrono::steady_clock::time_point> started_;
  std::map<std::string, std::string> started_utc_;
  std::map<std::string, double> durations_;
  std::vector<std::string> failures_;
  std::set<std::string> ran_, would_run_;
  int up_to_date_ = 0;
  std::chrono::steady_clock::time_point last_progress_{};
  std::string last_progress_text_;
};

std::string Runner::Ordinal(const Step& step) const {
  int k = 0, n = 0;
  for (const Step& s : graph_.steps()) {
    if (!selection_.Selected(s)) continue;
    ++n;
    if (s.name == step.name) k = n;
  }
  return "[" + std::to_string(k) + "/" + std::to_string(n) + (graph_.expanded() ? "" : "+") + "]";
}

void Runner::Preflight() {
  // A missing stage executable is reported before anything runs, for every
  // selected step that has never been accepted (so it must run).
  std::map<std::string, std::vector<std::string>> missing;  // exe -> steps
  for (const Step& s : graph_.steps()) {
    if (!selection_.Selected(s)) continue;
    if (!tools_.Find(s.tool).empty() || !lock_.OutputHash(s.name).empty()) continue;
    missing[s.tool].push_back(s.name);
  }
  std::vector<std::string> lines;
  for (const auto& [tool, steps] : missing) {
    lines.push_back(StageExecutables().at(tool) + " (for " + Join(steps, ", ") + "; looked in " +
                    tools_.Searched(tool) + ")");
  }
  RELIT_REQUIRE(lines.empty(), "stage executables not found: ", Join(lines, "; "),
                ". Build them (tools/build) or set their paths under tools: in ", config_.file,
                ", or stop earlier with --to STEP");
}

// Every selector must name a step. The partition steps (train-KK,
// augment-KK) exist once plan has run, so before that they are only checked
// at the end (final_check), unless a dry run's plan would run.
void Runner::CheckSelectors(bool final_check) const {
  for (const std::string& selector : selection_.Selectors()) {
    bool found = false;
    for (const Step& step : graph_.steps()) found = found || SelectorMatches(selector, step);
    if (found) continue;
    const bool partition_kind = selector.rfind("train", 0) == 0 || selector.rfind("augment", 0) == 0;
    if (partition_kind && !graph_.expanded()) {
      const auto plan = states_.find("plan");
      if (!final_check || (plan != states_.end() && plan->second == State::kWouldRun)) continue;
      Fail("step '", selector, "' does not exist yet: the train-KK and augment-KK steps come from the plan, and ",
           w_, "/relight/plan/plan.json is missing; run relit run --to plan first");
    }
    std::vector<std::string> names;
    for (const Step& step : graph_.steps()) names.push_back(step.name);
    Fail("step '", selector, "' is not part of this pipeline (", config_.file, "); its steps are ",
         Join(names, ", "), selector.rfind("augment", 0) == 0 ? " (augment runs when relight.augment is set up)" : "");
  }
}

void Runner::MaybeExpand() {
  if (graph_.expanded() || !graph_.Find("plan")) return;
  const State plan = states_.at("plan");
  if (!Settled(plan)) return;
  if (plan == State::kWouldRun) return;  // dry run: the new plan is not known
  if (plan == State::kFailed || plan == State::kBlocked) return;  // dependents are blocked
  std::error_code error;
  if (!fs::exists(fs::path(w_) / "relight" / "plan" / "plan.json", error)) {
    for (const Step& s : graph_.steps()) {
      const bool waits = s.kind == "render" || s.kind == "export" || s.kind == "eval" || s.kind == "report";
      if (!waits || states_.at(s.name) != State::kPending) continue;
      if (selection_.Selected(s)) {
        failures_.push_back(s.name + ": no relight plan (" + w_ +
                            "/relight/plan/plan.json); run the plan step first");
        states_[s.name] = State::kBlocked;
      } else {
        states_[s.name] = State::kSkipped;
      }
    }
    return;
  }
  graph_.ExpandPartitions(ReadPlanPartitions(w_));
  for (const Step& s : graph_.steps()) states_.emplace(s.name, State::kPending);
  if (!options_.dry_run) {
    // Partitions of an earlier plan that no longer exist.
    for (const std::string& name : lock_.StepNames()) {
      if (name.rfind("train-", 0) == 0 && !graph_.Find(name)) lock_.Remove(name);
    }
    lock_.Save();
  }
}

Job Runner::Prepare(const Step& step, const Evaluation& e) {
  fs::create_directories(StepDir(step));
  const std::string config_path = StepDir(step) + "/config.yaml";
  if (!step.config_yaml.empty()) AtomicWriteFile(config_path, step.config_yaml);
  Job job;
  job.step = step.name;
  job.kind = step.kind;
  job.array_index = step.partition;
  job.argv.push_back(e.tool_path);
  for (const std::string& a : step.args) job.argv.push_back(a == "{config}" ? config_path : a);
  job.step_dir = StepDir(step);
  job.log_path = LogPath(step);
  job.work_dir = w_;
  std::string command;
  for (const std::string& a : job.argv) command += (command.empty() ? "" : " ") + ShellQuote(a);
  started_utc_[step.name] = CurrentTimeIso8601Utc();
  lock_.Set(step.name, {{"status", "running"},
                        {"started_utc", started_utc_[step.name]},
                        {"pid", static_cast<int>(::getpid())},
                        {"command", command},
                        {"log", job.log_path}});
  lock_.Save();
  evaluations_[step.name] = e;
  started_[step.name] = std::chrono::steady_clock::now();
  states_[step.name] = State::kRunning;
  out_ << Ordinal(step) << " " << step.name << ": running (" << Join(e.reasons, "; ") << "); log "
       << job.log_path << std::endl;
  return job;
}

bool Runner::Schedule(std::map<std::string, std::vector<Job>>* slurm_batches) {
  bool changed = false;
  for (const Step& step : graph_.steps()) {
    State& state = states_[step.name];
    if (state != State::kPending) continue;
    bool deps_settled = true, deps_failed = false;
    std::vector<std::string> will_run;
    for (const std::string& d : step.deps) {
      const State ds = states_.at(d);
      if (!Settled(ds)) deps_settled = false;
      if (ds == State::kFailed || ds == State::kBlocked) deps_failed = true;
      if (ds == State::kWouldRun) will_run.push_back(d);
    }
    if (!deps_settled) continue;
    const bool needs_partitions =
        step.kind == "render" || step.kind == "export" || step.kind == "eval" || step.kind == "report";
    if (deps_failed) {
      state = State::kBlocked;
      changed = true;
      continue;
    }
    // Render, export and report wait for the train steps, which exist once
    // plan settled (MaybeExpand); in a dry run a plan that would run stands
    // for its partitions.
    if (needs_partitions && !graph_.expanded() && states_.at("plan") != State::kWouldRun) continue;
    if (!selection_.Selected(step)) {
      state = State::kSkipped;
      changed = true;
      continue;
    }
    // An upstream step left out by --only/--from/--to must have an accepted output.
    std::vector<std::string> unmet;
    for (const std::string& d : step.deps) {
      if (states_.at(d) == State::kSkipped && lock_.OutputHash(d).empty()) unmet.push_back(d);
    }
    if (!unmet.empty()) {
      state = State::kBlocked;
      changed = true;
      failures_.push_back(step.name + ": upstream " + Join(unmet, ", ") +
                          " has not run yet; run it first (or leave out --only/--from)");
      continue;
    }
    // A local step waiting for a job slot stays pending (and is evaluated
    // when it gets one, against the lock as it is then).
    if (!options_.dry_run && !OnSlurm(step) && static_cast<int>(local_.running()) >= jobs_) continue;
    changed = true;
    const std::string tool = tools_.Find(step.tool);
    Evaluation e = Evaluate(step, lock_, hashes_, OutputDir(step), tool, tools_.Searched(step.tool));
    if (!will_run.empty()) {
      // "will run" says more than "has no accepted output" (dry run).
      e.reasons.erase(std::remove_if(e.reasons.begin(), e.reasons.end(),
                                     [](const std::string& r) { return r.rfind("upstream step ", 0) == 0; }),
                      e.reasons.end());
      e.stale = true;
      e.reasons.insert(e.reasons.begin(), "upstream " + Join(will_run, ", ") + " will run");
    }
    if (selection_.Forced(step)) {
      e.stale = true;
      e.reasons.insert(e.reasons.begin(), "forced");
    }
    if (!e.stale) {
      state = State::kUpToDate;
      ++up_to_date_;
      continue;
    }
    if (options_.dry_run) {
      state = State::kWouldRun;
      would_run_.insert(step.name);
      out_ << "would run " << step.name << ": " << Join(e.reasons, "; ") << "\n";
      if (step.kind == "plan") {
        out_ << "would run train-KK for each partition of the new plan (known after plan runs)\n";
      }
      continue;
    }
    if (e.tool_missing) {
      state = State::kFailed;
      failures_.push_back(step.name + ": " + e.reasons.front());
      continue;
    }
    if (OnSlurm(step)) {
      (*slurm_batches)[step.kind].push_back(Prepare(step, e));
    } else {
      local_.Submit({Prepare(step, e)});
      RecordJobId(step.name, local_.JobIdOf(step.name));
    }
  }
  return changed;
}

void Runner::Complete(const JobResult& result) {
  const Step* step = graph_.Find(result.step);
  RELIT_CHECK(step != nullptr);
  const double seconds = SecondsSince(started_.at(step->name));
  const Evaluation& e = evaluations_.at(step->name);
  durations_[step->name] = seconds;
  std::string message = result.message;
  std::string output;
  if (result.ok) {
    output = hashes_.HashPath(OutputDir(*step));
    if (output.empty()) message = "exited 0 but wrote no output " + OutputDir(*step);
  }
  if (result.ok && !output.empty()) {
    lock_.Set(step->name, {{"status", "done"},
                           {"tool", {{"path", e.tool_path}, {"sha256", e.tool_sha256}}},
                           {"params", step->params},
                           {"params_sha256", e.params_sha256},
                           {"inputs", e.inputs},
                           {"output", {{"path", step->output}, {"sha256", output}}},
                           {"started_utc", started_utc_[step->name]},
                           {"finished_utc", CurrentTimeIso8601Utc()},
                           {"duration_s", seconds},
                           {"job", result.job_id},
                           {"log", LogPath(*step)}});
    states_[step->name] = State::kDone;
    ran_.insert(step->name);
    out_ << Ordinal(*step) << " " << step->name << ": done in " << FormatDuration(seconds) << std::endl;
  } else {
    lock_.Set(step->name, {{"status", "failed"},
                           {"exit_code", result.exit_code},
                           {"message", message},
                           {"job", result.job_id},
                           {"started_utc", started_utc_[step->name]},
                           {"finished_utc", CurrentTimeIso8601Utc()},
                           {"log", LogPath(*step)}});
    states_[step->name] = State::kFailed;
    std::string text = step->name + ": " + message + " (" + result.job_id + "); log " + LogPath(*step);
    const std::string tail = LogTail(LogPath(*step), 8);
    if (!tail.empty()) text += "\n    last lines of the log:\n" + Indent(tail, "      ");
    failures_.push_back(text);
    out_ << Ordinal(*step) << " " << step->name << ": FAILED after " << FormatDuration(seconds) << ": "
         << message << std::endl;
  }
  lock_.Save();
  hashes_.Save();
}

void Runner::ShowProgress(bool force) {
  std::vector<std::string> running;
  for (const Step& s : graph_.steps()) {
    if (states_.at(s.name) == State::kRunning) running.push_back(s.name);
  }
  if (running.empty()) return;
  const Step& first = *graph_.Find(running.front());
  const double seconds = SecondsSince(started_.at(first.name));
  std::string text = Ordinal(first) + " " + first.name + " " + FormatDuration(seconds);
  if (running.size() > 1) text += " (+" + std::to_string(running.size() - 1) + " running)";
  const std::string line = LastLogLine(LogPath(first));
  if (!line.empty()) text += " | " + line;
  const auto now = std::chrono::steady_clock::now();
  if (::isatty(2)) {
    if (!force && now - last_progress_ < std::chrono::milliseconds(500)) return;
    last_progress_ = now;
    std::cerr << "\r\033[K" << text.substr(0, 150) << std::flush;
  } else if (force || (line != last_progress_text_ && now - last_progress_ > std::chrono::seconds(30))) {
    last_progress_ = now;
    last_progress_text_ = line;
    out_ << "  ... " << text << std::endl;
  }
}

void Runner::WriteRunRecord(int code) {
  RunRecord record("relit");
  record.SetOptions({{"pipeline", config_.file},
                     {"workspace", w_},
                     {"only", options_.only},
                     {"from", options_.from},
                     {"to", options_.to},
                     {"force", options_.force},
                     {"jobs", jobs_},
                     {"executor", config_.executor}});
  for (const auto& [name, seconds] : durations_) record.AddTiming(name, seconds);
  record.Set("ran", std::vector<std::string>(ran_.begin(), ran_.end()));
  record.Set("up_to_date", up_to_date_);
  record.Set("failures", failures_);
  record.Set("exit_code", code);
  record.Write((fs::path(w_) / ".relit" / "run.json").string());
}

int Runner::Finish(int code) {
  if (::isatty(2)) std::cerr << "\r\033[K" << std::flush;
  if (code == 0) CheckSelectors(/*final_check=*/true);
  if (!options_.dry_run) WriteRunRecord(code);
  if (options_.dry_run) {
    if (!failures_.empty()) {
      // The real run would stop here: a dry run must not look like success.
      out_ << std::flush;
      err_ << "relit run --dry-run: " << failures_.size() << " step(s) could not run:\n";
      for (const std::string& f : failures_) err_ << "  " << f << "\n";
      err_ << std::flush;
      return 1;
    }
    if (would_run_.empty()) out_ << "everything is up to date; nothing would run\n";
    return 0;
  }
  if (!failures_.empty()) {
    out_ << std::flush;
    err_ << "relit run: " << failures_.size() << " step(s) failed:\n";
    for (const std::string& f : failures_) err_ << "  " << f << "\n";
    err_ << "fix the cause and run relit run again: accepted steps are not redone" << std::endl;
    hashes_.Save();
    return code == 0 ? 1 : code;
  }
  hashes_.Save();
  if (ran_.empty()) {
    out_ << "everything is up to date (" << up_to_date_ << " steps); nothing to run" << std::endl;
  } else {
    out_ << "relit run: " << ran_.size() << " step(s) ran, " << up_to_date_ << " up to date" << std::endl;
  }
  return code;
}

int Runner::Run() {
  CheckSelectors(/*final_check=*/false);
  if (!options_.dry_run) Preflight();
  std::unique_ptr<WorkspaceRunLock> run_lock;
  if (!options_.dry_run) run_lock = std::make_unique<WorkspaceRunLock>(w_);
  g_signal = 0;
  auto previous_int = std::signal(SIGINT, OnSignal);
  auto previous_term = std::signal(SIGTERM, OnSignal);
  int code = 0;
  try {
    while (true) {
      if (g_signal != 0) {
        out_ << "\ninterrupted: stopping running steps; relit run resumes where it stopped" << std::endl;
        local_.CancelAll();
        if (slurm_) slurm_->CancelAll();
        code = 130;
        break;
      }
      std::map<std::string, std::vector<Job>> batches;
      bool changed = Schedule(&batches);
      for (auto& [kind, jobs] : batches) {
        slurm_->Submit(jobs);
        for (const Job& job : jobs) RecordJobId(job.step, slurm_->JobIdOf(job.step));
      }
      const size_t before = graph_.steps().size();
      const auto states_before = states_;
      MaybeExpand();
      changed = changed || graph_.steps().size() != before || states_ != states_before || !batches.empty();
      const size_t running = local_.running() + (slurm_ ? slurm_->running() : 0);
      if (!changed && running == 0) break;
      std::vector<JobResult> results = local_.Poll();
      if (slurm_) {
        for (JobResult& r : slurm_->Poll()) results.push_back(std::move(r));
      }
      for (const JobResult& r : results) Complete(r);
      if (results.empty() && !changed) {
        ShowProgress(false);
        std::this_thread::sleep_for(std::chrono::duration<double>(options_.poll_interval_s));
      }
    }
  } catch (...) {
    local_.CancelAll();
    if (slurm_) slurm_->CancelAll();
    std::signal(SIGINT, previous_int);
    std::signal(SIGTERM, previous_term);
    throw;
  }
  std::signal(SIGINT, previous_int);
  std::signal(SIGTERM, previous_term);
  return Finish(code);
}

}  // namespace

int RunPipeline(const PipelineConfig& config, const RunOptions& options, std::ostream& out, std::ostream* err) {
  RELIT_REQUIRE(!options.workspace.empty(), "no workspace: pass --workspace W");
  RunOptions absolute = options;
  absolute.workspace = fs::absolute(options.workspace).lexically_normal().string();
  std::error_code error;
  const fs::file_status status = fs::status(absolute.workspace, error);
  RELIT_REQUIRE(status.type() == fs::file_type::not_found || status.type() == fs::file_type::directory,
                "--workspace ", options.workspace, " is a file, not a folder: give a folder path (relit run "
                "creates it)");
  if (!options.dry_run) fs::create_directories(fs::path(absolute.workspace) / ".relit");
  Runner runner(config, absolute, out, err ? *err : out);
  return runner.Run();
}

}  // namespace relit::pipeline
