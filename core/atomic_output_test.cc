#include "core/atomic_output.h"

#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"

namespace relit {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class AtomicOutputTest : public testing::Test {
 protected:
  void SetUp() override {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("relit_atomic_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static std::string ReadText(const fs::path& path) {
    std::ifstream stream(path);
    std::ostringstream text;
    text << stream.rdbuf();
    return text.str();
  }
  static void WriteText(const fs::path& path, const std::string& text) {
    std::ofstream(path) << text;
  }
  // Names in root_ starting with ".", i.e. temporaries.
  int CountHidden() const {
    int count = 0;
    for (const auto& entry : fs::directory_iterator(root_)) {
      if (entry.path().filename().string()[0] == '.') ++count;
    }
    return count;
  }

  fs::path root_;
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

}  // namespace
}  // namespace relit
