// The runner with real (small) stage executables: rerun rules on content,
// downstream-only reruns, selections, dry run, status, failures, the job
// pool, dynamic partitions and an interrupted run that must not be accepted.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/json_file.h"
#include "pipeline/executor.h"
#include "pipeline/run_support.h"
#include "pipeline/runner.h"
#include "pipeline/test_support.h"

namespace relit::pipeline {
namespace {

namespace fs = std::filesystem;
using testing::CalledSteps;
using testing::ReadText;
using testing::WriteText;

using Steps = std::vector<std::string>;
const Steps kAll = {"capture", "calib",    "reconstruct", "cues",   "plan",
                    "train-00", "train-01", "train-02",   "render", "report"};

class PipelineRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    bin_ = dir_.path() / "bin";
    testing::WriteStageScripts(bin_);
    calls_ = dir_.path() / "calls.txt";
    ::setenv("RELIT_TEST_CALLS", calls_.c_str(), 1);
    ::unsetenv("RELIT_TEST_FAIL");
    ::unsetenv("RELIT_TEST_SLEEP_S");
    ::unsetenv("RELIT_TEST_TIMES");
    ::unsetenv("RELIT_TEST_TRAIN_MARK");
    yaml_ = testing::WriteScriptPipeline(dir_.path(), bin_, kStages);
    workspace_ = dir_.path() / "ws";
  }

  // Runs the pipeline; returns the exit code, the output in *out and the
  // steps that ran (sorted for comparisons; partitions may run in parallel).
  int Run(RunOptions options, std::string* out = nullptr, Steps* ran = nullptr) {
    fs::remove(calls_);
    options.workspace = workspace_.string();
    options.poll_interval_s = 0.02;
    std::ostringstream text;
    const int code = RunPipeline(PipelineConfig::Load(yaml_.string()), options, text);
    if (out) *out = text.str();
    if (ran) {
      *ran = fs::exists(calls_) ? CalledSteps(calls_) : Steps{};
      std::sort(ran->begin(), ran->end(), [](const std::string& a, const std::string& b) {
        return std::find(kAll.begin(), kAll.end(), a) < std::find(kAll.begin(), kAll.end(), b);
      });
    }
    return code;
  }
  Steps RunSteps(RunOptions options = {}) {
    Steps ran;
    std::string out;
    EXPECT_EQ(Run(options, &out, &ran), 0) << out;
    return ran;
  }
  void EditYaml(const std::string& from, const std::string& to) {
    std::string text = ReadText(yaml_);
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    WriteText(yaml_, text);
  }
  nlohmann::json Lock() { return ReadJsonFile((workspace_ / "relit.lock.json").string(), "lock", 1); }

  static constexpr const char* kStages =
      "capture: {view_select: {target_frames: 50}}\n"
      "calib: {detect: {min_corners: 8}}\n"
      "reconstruct: {atlas: {resolution_px: 256}}\n"
      "relight:\n  dataset: {holdout_every: 3}\n  train: {steps: 10}\n  cues: {samples_per_pixel: 2}\n";

  testing::TempDir dir_;
  fs::path bin_, calls_, yaml_, workspace_;
};

TEST_F(PipelineRunTest, FirstRunRunsEverythingAndASecondRunNothing) {
  std::string out;
  Steps ran;
  ASSERT_EQ(Run({}, &out, &ran), 0) << out;
  EXPECT_EQ(ran, kAll);
  EXPECT_TRUE(fs::exists(workspace_ / "report" / "index.html"));
  EXPECT_TRUE(fs::exists(workspace_ / ".relit" / "steps" / "calib" / "log.txt"));
  EXPECT_NE(ReadText(workspace_ / ".relit" / "steps" / "calib" / "config.yaml").find("min_corners: 8"),
            std::string::npos);
  const nlohmann::json lock = Lock();
  for (const std::string& step : kAll) {
    EXPECT_EQ(lock["steps"][step]["status"], "done") << step;
  }
  EXPECT_EQ(lock["steps"]["calib"]["inputs"].count("step:capture"), 1u);
  EXPECT_EQ(lock["steps"]["capture"]["inputs"].count("inputs.view"), 1u);

  ASSERT_EQ(Run({}, &out, &ran), 0) << out;
  EXPECT_TRUE(ran.empty());
  EXPECT_NE(out.find("everything is up to date"), std::string::npos) << out;
  EXPECT_EQ(Lock(), lock);
}

TEST_F(PipelineRunTest, EditingAParameterRerunsOnlyThatStepAndDownstream) {
  RunSteps();
  EditYaml("train: {steps: 10}", "train: {steps: 20}");
  EXPECT_EQ(RunSteps(), (Steps{"train-00", "train-01", "train-02", "render", "report"}));
  EditYaml("cues: {samples_per_pixel: 2}", "cues: {samples_per_pixel: 3}");
  // New cues change the cue files, so training and everything after reruns.
  EXPECT_EQ(RunSteps(), (Steps{"cues", "train-00", "train-01", "train-02", "render", "report"}));
  EditYaml("min_corners: 8", "min_corners: 9");
  EXPECT_EQ(RunSteps(), (Steps{"calib", "reconstruct", "cues", "plan", "train-00", "train-01",
                               "train-02", "render", "report"}));
  // Log levels are not parameters.
  EditYaml("calib: {detect:", "calib: {log_level: debug, detect:");
  EXPECT_TRUE(RunSteps().empty());
}

TEST_F(PipelineRunTest, ReplacingAnInputRerunsEverythingDownstreamButTouchingItDoesNot) {
  RunSteps();
  // Same bytes, new modification time: content decides, nothing reruns.
  WriteText(dir_.path() / "capture" / "view.mp4", "phone V video bytes\n");
  EXPECT_TRUE(RunSteps().empty());
  WriteText(dir_.path() / "capture" / "view.mp4", "another phone V video\n");
  EXPECT_EQ(RunSteps(), kAll);
}

TEST_F(PipelineRunTest, ARebuiltToolRerunsItsStepsAndTheirDownstream) {
  RunSteps();
  const std::string script = ReadText(bin_ / "relit-reconstruct");
  // A rebuild that changes the tool but not what it writes: only its step.
  WriteText(bin_ / "relit-reconstruct", script + "# rebuilt\n");
  EXPECT_EQ(RunSteps(), (Steps{"reconstruct"}));
  // One that changes its output: everything downstream too.
  WriteText(bin_ / "relit-reconstruct", script + "echo v2 >>\"$W/reconstruct/proxy.txt\"\n");
  EXPECT_EQ(RunSteps(), (Steps{"reconstruct", "cues", "plan", "train-00", "train-01", "train-02",
                               "render", "report"}));
}

TEST_F(PipelineRunTest, UnchangedOutputsStopTheRerunEarly) {
  RunSteps();
  // capture reruns but writes the same bytes: calib and later stay valid.
  RunOptions options;
  options.force = {"capture"};
  EXPECT_EQ(RunSteps(options), (Steps{"capture"}));
}

TEST_F(PipelineRunTest, AnOutputChangedOrRemovedByHandIsRemade) {
  RunSteps();
  WriteText(workspace_ / "calib" / "calib.txt", "edited\n");
  std::string out;
  Steps ran;
  ASSERT_EQ(Run({}, &out, &ran), 0);
  EXPECT_EQ(ran, (Steps{"calib"}));  // remade identically: downstream still valid
  EXPECT_NE(out.find("changed since relit accepted it"), std::string::npos) << out;
  fs::remove_all(workspace_ / "relight" / "partitions" / "01");
  EXPECT_EQ(RunSteps(), (Steps{"train-01"}));
}

TEST_F(PipelineRunTest, DryRunSaysWhatWouldRunAndWhyWithoutRunningIt) {
  RunSteps();
  const std::string lock_before = ReadText(workspace_ / "relit.lock.json");
  EditYaml("resolution_px: 256", "resolution_px: 512");
  RunOptions options;
  options.dry_run = true;
  std::string out;
  Steps ran;
  ASSERT_EQ(Run(options, &out, &ran), 0);
  EXPECT_TRUE(ran.empty());
  EXPECT_NE(out.find("would run reconstruct: parameter reconstruct.atlas.resolution_px (256 -> 512) changed"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("would run cues: upstream reconstruct will run"), std::string::npos) << out;
  EXPECT_NE(out.find("would run train-KK for each partition"), std::string::npos) << out;
  EXPECT_NE(out.find("would run render: upstream"), std::string::npos) << out;
  EXPECT_EQ(out.find("would run calib"), std::string::npos) << out;
  EXPECT_EQ(ReadText(workspace_ / "relit.lock.json"), lock_before);

  // Nothing changed: the dry run says so.
  EditYaml("resolution_px: 512", "resolution_px: 256");
  ASSERT_EQ(Run(options, &out, &ran), 0);
  EXPECT_NE(out.find("everything is up to date; nothing would run"), std::string::npos) << out;
}

TEST_F(PipelineRunTest, StatusShowsUpToDateStaleReasonsAndFailures) {
  auto status_of = [&](const std::string& name) {
    for (const StepStatus& s : PipelineStatus(PipelineConfig::Load(yaml_.string()), workspace_.string())) {
      if (s.name == name) return s;
    }
    StepStatus missing;
    missing.name = name;
    missing.state = "(missing)";
    return missing;
  };
  fs::create_directories(workspace_);
  EXPECT_EQ(status_of("capture").state, "not run yet");
  EXPECT_EQ(status_of("train-KK").state, "waiting");  // partitions come from plan
  RunSteps();
  EXPECT_EQ(status_of("train-02").state, "up to date");
  EXPECT_EQ(status_of("report").state, "up to date");
  EditYaml("min_corners: 8", "min_corners: 12");
  const StepStatus calib = status_of("calib");
  EXPECT_EQ(calib.state, "stale");
  ASSERT_FALSE(calib.reasons.empty());
  EXPECT_EQ(calib.reasons[0], "parameter calib.detect.min_corners (8 -> 12) changed");
  EXPECT_EQ(status_of("capture").state, "up to date");
  EXPECT_EQ(status_of("render").state, "stale");  // because of calib, upstream

  ::setenv("RELIT_TEST_FAIL", "calib", 1);
  std::string out;
  EXPECT_EQ(Run({}, &out), 1);
  ::unsetenv("RELIT_TEST_FAIL");
  const StepStatus failed = status_of("calib");
  EXPECT_EQ(failed.state, "failed");
  ASSERT_FALSE(failed.reasons.empty());
  EXPECT_NE(failed.reasons[0].find("exit code 3"), std::string::npos) << failed.reasons[0];
  std::ostringstream printed;
  PrintStatus(PipelineStatus(PipelineConfig::Load(yaml_.string()), workspace_.string()), printed);
  EXPECT_NE(printed.str().find("log " + (workspace_ / ".relit/steps/calib/log.txt").string()),
            std::string::npos)
      << printed.str();
}

TEST_F(PipelineRunTest, AFailedStepStopsItsDownstreamAndIsReportedWithItsLog) {
  ::setenv("RELIT_TEST_FAIL", "train-01", 1);
  std::string out;
  Steps ran;
  EXPECT_EQ(Run({}, &out, &ran), 1);
  // The other partitions still ran; render and report did not.
  EXPECT_EQ(ran, (Steps{"capture", "calib", "reconstruct", "cues", "plan", "train-00", "train-01",
                        "train-02"}));
  EXPECT_NE(out.find("train-01: exit code 3"), std::string::npos) << out;
  EXPECT_NE(out.find((workspace_ / ".relit/steps/train-01/log.txt").string()), std::string::npos) << out;
  EXPECT_NE(out.find("failing on purpose: train-01"), std::string::npos) << out;  // the log's tail
  EXPECT_EQ(Lock()["steps"]["train-01"]["status"], "failed");
  ::unsetenv("RELIT_TEST_FAIL");
  EXPECT_EQ(RunSteps(), (Steps{"train-01", "render", "report"}));
}

TEST_F(PipelineRunTest, OnlyFromToAndForceSelectSteps) {
  RunOptions to;
  to.to = {"reconstruct"};
  EXPECT_EQ(RunSteps(to), (Steps{"capture", "calib", "reconstruct"}));
  RunOptions only;
  only.only = {"plan"};  // its upstream ran; cues has not and is not needed
  EXPECT_EQ(RunSteps(only), (Steps{"plan"}));
  RunSteps();
  EditYaml("min_corners: 8", "min_corners: 10");
  EditYaml("train: {steps: 10}", "train: {steps: 11}");
  only.only = {"train"};  // the group: every partition; calib stays stale
  EXPECT_EQ(RunSteps(only), (Steps{"train-00", "train-01", "train-02"}));
  RunOptions from;
  from.from = {"train-01"};
  from.to = {"render"};
  EXPECT_EQ(RunSteps(from), (Steps{"train-01", "render"}));
  RunOptions force;
  force.force = {"relight"};
  force.only = {"cues", "plan"};
  EXPECT_EQ(RunSteps(force), (Steps{"cues", "plan"}));
  std::string out;
  RunOptions bad;
  bad.only = {"trian"};
  EXPECT_THROW(Run(bad, &out), Error);
}

// Selections that name nothing, or a workspace that cannot be one, are
// errors, also in a dry run (which used to say "nothing would run").
TEST_F(PipelineRunTest, SelectionsThatRunNothingAreErrorsNotSuccess) {
  auto error_of = [&](RunOptions options) {
    std::string out;
    try {
      const int code = Run(options, &out);
      return "exit " + std::to_string(code) + ": " + out;
    } catch (const Error& e) {
      return std::string(e.what());
    }
  };
  RunOptions options;
  options.dry_run = true;
  options.from = {"train-99"};
  EXPECT_NE(error_of(options).find("relit run --to plan"), std::string::npos) << error_of(options);
  options.from = {"report"};
  options.to = {"capture"};
  EXPECT_NE(error_of(options).find("selects no step"), std::string::npos) << error_of(options);
  options.from.clear();
  options.to.clear();
  options.only = {"augment"};
  EXPECT_NE(error_of(options).find("augment"), std::string::npos) << error_of(options);
  EXPECT_EQ(error_of(options).rfind("exit 0", 0), std::string::npos) << error_of(options);
  // A step whose upstream never ran: the dry run says it could not run.
  options.only = {"calib"};
  std::string out;
  EXPECT_EQ(Run(options, &out), 1) << out;
  // Once the plan exists, a partition that is not in it is named.
  RunSteps();
  options.only = {"train-07"};
  EXPECT_NE(error_of(options).find("is not part of this pipeline"), std::string::npos) << error_of(options);
  // A workspace path that is a file.
  fs::remove_all(workspace_);
  WriteText(workspace_, "not a folder");
  options.only.clear();
  EXPECT_NE(error_of(options).find("is a file, not a folder"), std::string::npos) << error_of(options);
  EXPECT_EQ(ReadText(workspace_), "not a folder");
}

TEST_F(PipelineRunTest, PartitionsFollowThePlan) {
  RunSteps();
  EditYaml("dataset: {holdout_every: 3}", "dataset: {holdout_every: 2}");
  EXPECT_EQ(RunSteps(), (Steps{"plan", "train-00", "train-01", "render", "report"}));
  const nlohmann::json lock = Lock();
  EXPECT_FALSE(lock["steps"].contains("train-02"));
  EXPECT_TRUE(lock["steps"].contains("train-01"));
}

TEST_F(PipelineRunTest, TheExportStepExistsWhenTheRelightToolHasIt) {
  ::setenv("RELIT_TEST_EXPORT", "1", 1);
  Steps ran = RunSteps();
  ::unsetenv("RELIT_TEST_EXPORT");
  EXPECT_EQ(ran.size(), kAll.size() + 1);
  EXPECT_NE(std::find(ran.begin(), ran.end(), "export"), ran.end());
  EXPECT_TRUE(fs::exists(workspace_ / "relight" / "export" / "manifest.json"));
  // run.export: off drops the step (and report, which read its output, reruns).
  WriteText(yaml_, ReadText(yaml_) + "run: {export: off}\n");
  EXPECT_EQ(RunSteps(), (Steps{"report"}));
}

TEST_F(PipelineRunTest, TheJobPoolRunsPartitionsInParallelUpToTheJobCount) {
  const fs::path times = dir_.path() / "times.txt";
  ::setenv("RELIT_TEST_TIMES", times.c_str(), 1);
  ::setenv("RELIT_TEST_SLEEP_S", "0.6", 1);
  auto max_concurrent = [&]() {
    std::vector<std::pair<double, int>> events;
    std::istringstream in(ReadText(times));
    std::string name, what;
    double t;
    while (in >> name >> what >> t) events.push_back({t, what == "start" ? 1 : -1});
    std::sort(events.begin(), events.end());
    int now = 0, most = 0;
    for (const auto& e : events) most = std::max(most, now += e.second);
    return most;
  };
  RunOptions two;
  two.jobs = 2;
  RunSteps(two);
  EXPECT_EQ(max_concurrent(), 2);
  fs::remove(times);
  RunOptions one;
  one.jobs = 1;
  one.force = {"train"};
  RunSteps(one);
  EXPECT_EQ(max_concurrent(), 1);
}

#ifdef RELIT_EXECUTABLE
TEST_F(PipelineRunTest, AStepKilledMidwayIsNeverAcceptedAndRerunsNextTime) {
  const fs::path marks = dir_.path() / "marks";
  fs::create_directories(marks);
  ::setenv("RELIT_TEST_TRAIN_MARK", marks.c_str(), 1);
  ::setenv("RELIT_TEST_SLEEP_S", "30", 1);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, 1);
    ::dup2(null, 2);
    ::execl(RELIT_EXECUTABLE, RELIT_EXECUTABLE, "run", yaml_.c_str(), "--workspace",
            workspace_.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Kill the whole `relit run` as hard as possible once training started and
  // wrote its first checkpoint.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(marks / "train-00.started") && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(fs::exists(marks / "train-00.started"));
  // While it runs, status says so (with the step's pid and log line).
  for (const StepStatus& s : PipelineStatus(PipelineConfig::Load(yaml_.string()), workspace_.string())) {
    if (s.name == "train-00") {
      EXPECT_EQ(s.state, "running");
      ASSERT_FALSE(s.reasons.empty());
      EXPECT_EQ(s.reasons[0].rfind("pid ", 0), 0u) << s.reasons[0];
    }
    if (s.name == "capture") {
      EXPECT_EQ(s.state, "up to date");
    }
  }
  ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(fs::exists(workspace_ / "relight/partitions/00/checkpoint.txt"));  // half-done work
  EXPECT_FALSE(fs::exists(workspace_ / "relight/partitions/00/train.json"));
  EXPECT_EQ(Lock()["steps"]["train-00"]["status"], "running");
  bool interrupted = false;
  for (const StepStatus& s : PipelineStatus(PipelineConfig::Load(yaml_.string()), workspace_.string())) {
    if (s.name == "train-00") {
      interrupted = s.state == "stale" && !s.reasons.empty() && s.reasons[0].find("interrupted") == 0;
    }
  }
  EXPECT_TRUE(interrupted);

  ::setenv("RELIT_TEST_SLEEP_S", "0", 1);
  const Steps ran = RunSteps();
  EXPECT_NE(std::find(ran.begin(), ran.end(), "train-00"), ran.end());
  EXPECT_EQ(std::find(ran.begin(), ran.end(), "capture"), ran.end());  // accepted before the kill
  EXPECT_TRUE(fs::exists(workspace_ / "relight/partitions/00/train.json"));
  EXPECT_EQ(Lock()["steps"]["train-00"]["status"], "done");
  EXPECT_TRUE(RunSteps().empty());
}
#endif

TEST_F(PipelineRunTest, OneRunPerWorkspaceAtATime) {
  fs::create_directories(workspace_);
  WorkspaceRunLock holder(workspace_.string());
  std::string out;
  try {
    Run({}, &out);
    FAIL() << "a second run in the same workspace was allowed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("another relit run"), std::string::npos) << e.what();
  }
}

// Sets TMPDIR for one test and puts back what was there.
class ScopedTmpdir {
 public:
  explicit ScopedTmpdir(const char* value) {
    if (const char* old = std::getenv("TMPDIR")) saved_ = old;
    if (value) {
      ::setenv("TMPDIR", value, 1);
    } else {
      ::unsetenv("TMPDIR");
    }
  }
  ~ScopedTmpdir() {
    if (saved_) {
      ::setenv("TMPDIR", saved_->c_str(), 1);
    } else {
      ::unsetenv("TMPDIR");
    }
  }

 private:
  std::optional<std::string> saved_;
};

TEST(RunCaptureTest, KeepsACommandsStderrInTmpdir) {
  testing::TempDir tmp;
  ScopedTmpdir scoped(tmp.path().c_str());
  EXPECT_EQ(CommandStderrTemplate(), (tmp.path() / "relit-cmd-XXXXXX").string());
  // The command lists TMPDIR while it runs: its stderr file is there.
  std::string out, err;
  ASSERT_EQ(RunCapture("{ ls " + tmp.path().string() + "; echo oops >&2; }", &out, &err), 0);
  EXPECT_NE(out.find("relit-cmd-"), std::string::npos) << out;
  EXPECT_EQ(err, "oops\n");
  EXPECT_TRUE(fs::is_empty(tmp.path())) << "the stderr file was left behind";
}

TEST(RunCaptureTest, FallsBackToSlashTmp) {
  {
    ScopedTmpdir scoped(nullptr);
    EXPECT_EQ(CommandStderrTemplate(), "/tmp/relit-cmd-XXXXXX");
  }
  ScopedTmpdir scoped("/nonexistent/relit-tmpdir");
  EXPECT_EQ(CommandStderrTemplate(), "/tmp/relit-cmd-XXXXXX");
  std::string out, err;
  EXPECT_EQ(RunCapture("{ echo hi; echo oops >&2; }", &out, &err), 0);
  EXPECT_EQ(out, "hi\n");
  EXPECT_EQ(err, "oops\n");
}

}  // namespace
}  // namespace relit::pipeline
