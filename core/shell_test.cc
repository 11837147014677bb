#include "core/shell.h"

#include <gtest/gtest.h>

namespace relit {
namespace {

TEST(ShellTest, KeepsAllOfStdoutAndStderr) {
  // 200 000 bytes on each stream: more than any pipe or old 4 KiB tail.
  const CommandResult result = RunCommand(
      "i=0; while [ $i -lt 20000 ]; do echo line$i; echo err$i >&2; i=$((i+1)); done | "
      "awk '{print substr($0 \"..........\", 1, 9)}'");
  ASSERT_TRUE(result.ok());
  EXPECT_EQ(result.out.substr(0, 6), "line0.");
  EXPECT_NE(result.out.find("line19999"), std::string::npos);
  EXPECT_EQ(result.err.substr(0, 5), "err0\n");
  EXPECT_NE(result.err.find("err19999\n"), std::string::npos);
  EXPECT_GT(result.err.size(), 100000u);
  const std::string tail = result.ErrTail(100);
  EXPECT_EQ(tail.rfind("[last 100 of ", 0), 0u) << tail;
  EXPECT_NE(tail.find("err19999"), std::string::npos);
  EXPECT_EQ(RunCommand("echo short >&2").ErrTail(), "short\n");
}

TEST(ShellTest, ReportsFailure) {
  const CommandResult result = RunCommand("echo boom >&2; exit 3");
  EXPECT_FALSE(result.ok());
  EXPECT_EQ(ExitDescription(result.status), "exited with status 3");
  EXPECT_EQ(result.err, "boom\n");
}

}  // namespace
}  // namespace relit
