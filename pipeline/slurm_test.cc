// run.executor: slurm against a real single-node Slurm cluster started by the
// test (slurm_cluster.h): cue and training steps go through sbatch (training
// as one array job), results equal a local run, and a failing task is
// reported with its job id and log.
#include <sstream>

#include <gtest/gtest.h>

#include "core/json_file.h"
#include "pipeline/runner.h"
#include "pipeline/slurm_cluster.h"
#include "pipeline/test_support.h"

namespace relit::pipeline {
namespace {

namespace fs = std::filesystem;
using testing::ReadText;

class PipelineSlurmTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    cluster_ = testing::SlurmCluster::Start(dir_->path() / "slurm", &why_not_).release();
  }
  static void TearDownTestSuite() {
    delete cluster_;
    cluster_ = nullptr;
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (!cluster_) GTEST_SKIP() << "relit-skip: cannot start a local Slurm cluster: " << why_not_;
    bin_ = dir_->path() / "bin";
    testing::WriteStageScripts(bin_);
    ::setenv("RELIT_TEST_CALLS", (dir_->path() / "calls.txt").c_str(), 1);
    ::unsetenv("RELIT_TEST_FAIL");
    ::setenv("RELIT_TEST_SLEEP_S", "1", 1);
  }

  int Run(const std::string& name, const std::string& executor, std::string* out) {
    const fs::path dir = dir_->path() / name;
    const fs::path yaml = testing::WriteScriptPipeline(
        dir, bin_,
        "run: {executor: " + executor + "}\n"
        "slurm:\n  steps: [cues, train]\n  poll_s: 0.3\n"
        "  resources: {cpus: 1, memory: 200M, time: '00:05:00'}\n"
        "relight: {dataset: {holdout_every: 3}, train: {steps: 10}}\n");
    RunOptions options;
    options.workspace = (dir / "ws").string();
    options.poll_interval_s = 0.05;
    std::ostringstream text;
    const int code = RunPipeline(PipelineConfig::Load(yaml.string()), options, text);
    *out = text.str();
    return code;
  }

  static testing::TempDir* dir_;
  static testing::SlurmCluster* cluster_;
  static std::string why_not_;
  fs::path bin_;
};

testing::TempDir* PipelineSlurmTest::dir_ = nullptr;
testing::SlurmCluster* PipelineSlurmTest::cluster_ = nullptr;
std::string PipelineSlurmTest::why_not_;

TEST_F(PipelineSlurmTest, TrainingThroughSlurmEqualsALocalRun) {
  std::string local_out, slurm_out;
  ASSERT_EQ(Run("local", "local", &local_out), 0) << local_out;
  ASSERT_EQ(Run("slurm", "slurm", &slurm_out), 0) << slurm_out << cluster_->Logs();
  const fs::path a = dir_->path() / "local" / "ws", b = dir_->path() / "slurm" / "ws";
  for (const char* file : {"relight/cues/cues.txt", "relight/plan/plan.json", "relight/partitions/00/train.json",
                           "relight/partitions/01/train.json", "relight/partitions/02/train.json",
                           "relight/render/render.json", "report/index.html"}) {
    ASSERT_TRUE(fs::exists(b / file)) << file;
    EXPECT_EQ(ReadText(a / file), ReadText(b / file)) << file;
  }
  const nlohmann::json lock = ReadJsonFile((b / "relit.lock.json").string(), "lock", 1);
  // Training went out as one array job (task = partition), cues as a job.
  const std::string train0 = lock["steps"]["train-00"]["job"], train2 = lock["steps"]["train-02"]["job"];
  const std::string cues = lock["steps"]["cues"]["job"];
  ASSERT_NE(train0.find('_'), std::string::npos) << train0;
  EXPECT_EQ(train0.substr(train0.find('_')), "_0");
  EXPECT_EQ(train2, train0.substr(0, train0.find('_')) + "_2");
  EXPECT_EQ(cues.find('_'), std::string::npos) << cues;
  EXPECT_EQ(lock["steps"]["calib"]["job"].get<std::string>().rfind("pid ", 0), 0u);  // local
  EXPECT_NE(ReadText(b / ".relit/steps/train-01/log.txt").find("train train-01: step 2/2"), std::string::npos);

  // A second run through Slurm has nothing to do.
  ASSERT_EQ(Run("slurm", "slurm", &slurm_out), 0);
  EXPECT_NE(slurm_out.find("everything is up to date"), std::string::npos) << slurm_out;
}

TEST_F(PipelineSlurmTest, AFailingTaskIsReportedWithItsJobIdAndLog) {
  ::setenv("RELIT_TEST_FAIL", "train-01", 1);
  std::string out;
  EXPECT_EQ(Run("failing", "slurm", &out), 1);
  const fs::path ws = dir_->path() / "failing" / "ws";
  const nlohmann::json lock = ReadJsonFile((ws / "relit.lock.json").string(), "lock", 1);
  const std::string job = lock["steps"]["train-01"]["job"];
  EXPECT_EQ(lock["steps"]["train-01"]["status"], "failed");
  EXPECT_NE(out.find("Slurm job " + job + " failed with exit code 3"), std::string::npos) << out;
  EXPECT_NE(out.find((ws / ".relit/steps/train-01/log.txt").string()), std::string::npos) << out;
  EXPECT_EQ(lock["steps"]["train-00"]["status"], "done");
  EXPECT_FALSE(lock["steps"].contains("render"));
}

}  // namespace
}  // namespace relit::pipeline
