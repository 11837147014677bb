#include "core/atomic_output.h"

#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/test_dir.h"

namespace relit {
namespace {

namespace fs = std::filesystem;

using test_support::ReadText;
using test_support::WriteText;

class AtomicOutputTest : public test_support::TempDirTest {
 protected:
  AtomicOutputTest() : TempDirTest("relit_atomic_") {}

  // Names in root_ starting with ".", i.e. temporaries.
  int CountHidden() const {
    int count = 0;
    for (const auto& entry : fs::directory_iterator(root_)) {
      if (entry.path().filename().string()[0] == '.') ++count;
    }
    return count;
  }
};

TEST_F(AtomicOutputTest, WriteFileCreatesParentsAndReplaces) {
  const fs::path path = root_ / "a" / "b" / "out.txt";
  AtomicWriteFile(path, "first");
  EXPECT_EQ(ReadText(path), "first");
  AtomicWriteFile(path, "second, longer content");
  EXPECT_EQ(ReadText(path), "second, longer content");
  for (const auto& entry : fs::directory_iterator(path.parent_path())) {
    EXPECT_EQ(entry.path().filename(), "out.txt") << "temporary left behind";
  }
}

TEST_F(AtomicOutputTest, WriteFileIntoUnwritablePlaceNamesFile) {
  // A regular file where a directory is needed.
  WriteText(root_ / "blocker", "x");
  try {
    AtomicWriteFile(root_ / "blocker" / "out.txt", "content");
    FAIL() << "expected relit::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("out.txt"), std::string::npos) << e.what();
  }
}

TEST_F(AtomicOutputTest, UncommittedLeavesTargetUntouchedAndRemovesTemp) {
  const fs::path target = root_ / "frames";
  fs::create_directories(target);
  WriteText(target / "old.txt", "old");
  fs::path temp;
  {
    AtomicDir dir(target);
    temp = dir.path();
    EXPECT_EQ(temp.parent_path(), root_);
    EXPECT_EQ(temp.filename(), ".frames.tmp-" + std::to_string(getpid()));
    EXPECT_TRUE(fs::is_directory(temp));
    WriteText(dir.path() / "new.txt", "new");
  }
  EXPECT_FALSE(fs::exists(temp));
  EXPECT_EQ(ReadText(target / "old.txt"), "old");
  EXPECT_FALSE(fs::exists(target / "new.txt"));
  EXPECT_EQ(CountHidden(), 0);
}

TEST_F(AtomicOutputTest, UncommittedWithoutPreviousTargetLeavesNothing) {
  const fs::path target = root_ / "frames";
  {
    AtomicDir dir(target);
    WriteText(dir.path() / "new.txt", "new");
  }
  EXPECT_FALSE(fs::exists(target));
  EXPECT_EQ(CountHidden(), 0);
}

TEST_F(AtomicOutputTest, CommitReplacesTarget) {
  const fs::path target = root_ / "frames";
  fs::create_directories(target);
  WriteText(target / "old.txt", "old");
  {
    AtomicDir dir(target);
    WriteText(dir.path() / "new.txt", "new");
    dir.Commit();
    EXPECT_TRUE(dir.committed());
  }
  EXPECT_EQ(ReadText(target / "new.txt"), "new");
  EXPECT_FALSE(fs::exists(target / "old.txt"));
  EXPECT_EQ(CountHidden(), 0);
}

TEST_F(AtomicOutputTest, CommitWithoutPreviousTargetAndTrailingSlash) {
  AtomicDir dir((root_ / "out" / "nested").string() + "/");
  WriteText(dir.path() / "x.txt", "x");
  dir.Commit();
  EXPECT_EQ(ReadText(root_ / "out" / "nested" / "x.txt"), "x");
}

TEST_F(AtomicOutputTest, CommitTwiceIsABug) {
  AtomicDir dir(root_ / "frames");
  dir.Commit();
  EXPECT_THROW(dir.Commit(), Error);
}

TEST_F(AtomicOutputTest, MovedDirIsOwnedByTheNewObject) {
  const fs::path target = root_ / "frames";
  AtomicDir outer = [&] {
    AtomicDir dir(target);
    WriteText(dir.path() / "a.txt", "a");
    return dir;
  }();
  ASSERT_TRUE(fs::exists(outer.path() / "a.txt"));  // moved-from object removed nothing
  outer.Commit();
  EXPECT_EQ(ReadText(target / "a.txt"), "a");
}

TEST_F(AtomicOutputTest, StaleTemporariesOfDeadProcessesAreRemoved) {
  // pid 2^22 + 1 is above Linux's pid_max limit, so no process has it.
  const fs::path stale_tmp = root_ / ".frames.tmp-4194305";
  const fs::path stale_old = root_ / ".frames.old-4194305";
  const fs::path stale_file = root_ / ".frames.tmp-4194305-7";
  // pid 1 always runs: its temporaries belong to a live writer.
  const fs::path live = root_ / ".frames.tmp-1";
  // Another target's temporaries are not ours to remove.
  const fs::path other = root_ / ".frames2.tmp-4194305";
  for (const fs::path& p : {stale_tmp, stale_old, live, other}) fs::create_directories(p / "sub");
  WriteText(stale_file, "partial");

  AtomicDir dir(root_ / "frames");
  EXPECT_FALSE(fs::exists(stale_tmp));
  EXPECT_FALSE(fs::exists(stale_old));
  EXPECT_FALSE(fs::exists(stale_file));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(other));
}

TEST_F(AtomicOutputTest, StaleTempWithOwnPidIsReplaced) {
  // Containers often reuse the same pid across runs.
  const fs::path own = root_ / (".frames.tmp-" + std::to_string(getpid()));
  fs::create_directories(own);
  WriteText(own / "leftover.txt", "x");
  AtomicDir dir(root_ / "frames");
  EXPECT_TRUE(fs::is_directory(dir.path()));
  EXPECT_FALSE(fs::exists(dir.path() / "leftover.txt"));
}

// The output-folder rule (docs/refusals.md): what a guarded AtomicDir may
// replace. Each refusal leaves the folder and its files as they were.
TEST_F(AtomicOutputTest, GuardRefusesFilesForeignFoldersAndFoldersHoldingInputs) {
  const OutputGuard guard{"relit-test", false, {root_ / "user" / "v.mp4"}};
  fs::create_directories(root_ / "user");
  WriteText(root_ / "user" / "v.mp4", "video");
  WriteText(root_ / "user" / "notes.txt", "mine");
  WriteText(root_ / "file.txt", "mine");
  fs::create_directories(root_ / "foreign");
  WriteText(root_ / "foreign" / "a.txt", "mine");

  auto error_of = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  // The folder that holds an input: never, not even with --force.
  OutputGuard forced = guard;
  forced.force = true;
  EXPECT_NE(error_of([&] { AtomicDir(root_ / "user", forced); }).find("holds the input"),
            std::string::npos);
  EXPECT_NE(error_of([&] { AtomicDir(root_, forced); }).find("holds the input"), std::string::npos);
  // A regular file: never.
  EXPECT_NE(error_of([&] { AtomicDir(root_ / "file.txt", forced); }).find("never replaces a file"),
            std::string::npos);
  // A folder the stage did not write: only with --force.
  EXPECT_NE(error_of([&] { AtomicDir(root_ / "foreign", guard); }).find("--force"),
            std::string::npos);
  EXPECT_EQ(ReadText(root_ / "user" / "notes.txt"), "mine");
  EXPECT_EQ(ReadText(root_ / "file.txt"), "mine");
  EXPECT_EQ(ReadText(root_ / "foreign" / "a.txt"), "mine");
  {
    AtomicDir out(root_ / "foreign", forced);
    out.Commit();
  }
  EXPECT_FALSE(fs::exists(root_ / "foreign" / "a.txt"));
}

TEST_F(AtomicOutputTest, GuardReplacesEmptyAndOwnFolders) {
  const OutputGuard guard{"relit-test", false, {}};
  fs::create_directories(root_ / "empty");
  {
    AtomicDir out(root_ / "empty", guard);
    WriteText(out.path() / "x.txt", "1");
    out.Commit();
  }
  EXPECT_EQ(ReadText(root_ / "empty" / kOutputMarkerFile), "relit-test\n");
  {
    AtomicDir out(root_ / "empty", guard);  // has our marker now
    WriteText(out.path() / "x.txt", "2");
    out.Commit();
  }
  EXPECT_EQ(ReadText(root_ / "empty" / "x.txt"), "2");
  // Another stage's marker is not ours.
  EXPECT_THROW(AtomicDir(root_ / "empty", OutputGuard{"relit-other", false, {}}), Error);
  // Outputs written before the marker existed: run.json names the tool.
  fs::create_directories(root_ / "legacy");
  WriteText(root_ / "legacy" / "run.json", R"({"schema": "relit.run/1", "tool": "relit-test"})");
  EXPECT_NO_THROW(AtomicDir(root_ / "legacy", guard));
}

TEST_F(AtomicOutputTest, GuardCheckIsRepeatedAtCommit) {
  const OutputGuard guard{"relit-test", false, {}};
  AtomicDir out(root_ / "late", guard);
  fs::create_directories(root_ / "late");
  WriteText(root_ / "late" / "user.txt", "written while the stage ran");
  EXPECT_THROW(out.Commit(), Error);
  EXPECT_EQ(ReadText(root_ / "late" / "user.txt"), "written while the stage ran");
}

}  // namespace
}  // namespace relit
