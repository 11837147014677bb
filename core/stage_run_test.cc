#include "core/stage_run.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/json_file.h"
#include "core/test_dir.h"

namespace relit {
namespace {

namespace fs = std::filesystem;
using test_support::ReadText;

class StageRunTest : public test_support::TempDirTest {
 protected:
  StageRunTest() : TempDirTest("relit_stage_run_") {}

  StageRunSettings Settings() const { return {"relit-test", root_ / "out", false, {}, "--out", "test.log"}; }
  // Entries of root_: 1 once the output is in place and no temporary is left.
  int Entries() const { return static_cast<int>(std::distance(fs::directory_iterator(root_), {})); }
};

TEST_F(StageRunTest, CommitWritesTheRecordAndTheLogAndMovesTheFolder) {
  testing::internal::CaptureStderr();
  {
    StageRun run(Settings());
    EXPECT_FALSE(fs::exists(root_ / "out"));
    const int value = run.Step("work", [&] {
      std::ofstream(run.path() / "result.txt") << "result";
      return 7;
    });
    EXPECT_EQ(value, 7);
    spdlog::info("inside the run");
    run.record().Set("value", value);
    run.Commit();
  }
  spdlog::info("after the run");
  testing::internal::GetCapturedStderr();
  EXPECT_EQ(ReadText(root_ / "out" / "result.txt"), "result");
  const nlohmann::json record = ReadJsonFile((root_ / "out" / "run.json").string(), RunRecord::kKind, RunRecord::kVersion);
  EXPECT_EQ(record["tool"], "relit-test");
  EXPECT_EQ(record["value"], 7);
  EXPECT_TRUE(record["timings_s"].contains("work")) << record.dump();
  const std::string log = ReadText(root_ / "out" / "test.log");
  EXPECT_NE(log.find("inside the run"), std::string::npos) << log;
  EXPECT_EQ(log.find("after the run"), std::string::npos) << log;  // closed at Commit
  EXPECT_EQ(Entries(), 1) << "temporary left behind";
}

TEST_F(StageRunTest, AFailedRunLeavesThePreviousOutputAlone) {
  {
    StageRun first(Settings());
    std::ofstream(first.path() / "result.txt") << "first";
    first.Commit();
  }
  testing::internal::CaptureStderr();
  EXPECT_THROW(
      {
        StageRun second(Settings());
        std::ofstream(second.path() / "result.txt") << "second";
        second.Step("fail", [] { RELIT_REQUIRE(false, "the step failed"); });
      },
      Error);
  spdlog::info("after the failed run");
  testing::internal::GetCapturedStderr();
  EXPECT_EQ(ReadText(root_ / "out" / "result.txt"), "first");
  EXPECT_EQ(ReadText(root_ / "out" / "test.log").find("after the failed run"), std::string::npos);
  EXPECT_EQ(Entries(), 1) << "temporary left behind";
}

TEST_F(StageRunTest, TheGuardRefusesAFolderAnotherToolWrote) {
  fs::create_directories(root_ / "out");
  std::ofstream(root_ / "out" / "notes.txt") << "not ours";
  EXPECT_THROW(StageRun run(Settings()), Error);
  EXPECT_EQ(ReadText(root_ / "out" / "notes.txt"), "not ours");
  StageRunSettings forced = Settings();
  forced.force = true;
  StageRun run(forced);
  run.Commit();
  EXPECT_FALSE(fs::exists(root_ / "out" / "notes.txt"));
}

TEST_F(StageRunTest, ACallersRecordIsWrittenIntoTheFolder) {
  RunRecord record("relit-caller");
  record.Set("subcommand", "eval");
  StageRun run(AtomicDir(root_ / "eval"), record);
  run.Step("score", [] {});
  run.Commit();
  const nlohmann::json written = ReadJsonFile((root_ / "eval" / "run.json").string(), RunRecord::kKind, RunRecord::kVersion);
  EXPECT_EQ(written["tool"], "relit-caller");
  EXPECT_EQ(written["subcommand"], "eval");
  EXPECT_TRUE(written["timings_s"].contains("score"));
  EXPECT_FALSE(fs::exists(root_ / "eval" / "test.log"));
}

}  // namespace
}  // namespace relit
