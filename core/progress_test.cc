#include "core/progress.h"

#include <cstdlib>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace relit {
namespace {

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

TEST(Progress, FormatDuration) {
  EXPECT_EQ(FormatDuration(0), "0:00");
  EXPECT_EQ(FormatDuration(5.4), "0:05");
  EXPECT_EQ(FormatDuration(59.6), "1:00");
  EXPECT_EQ(FormatDuration(754), "12:34");
  EXPECT_EQ(FormatDuration(3600 + 62), "1:01:02");
  EXPECT_EQ(FormatDuration(-1), "--:--");
  EXPECT_EQ(FormatDuration(std::numeric_limits<double>::infinity()), "--:--");
}

TEST(Progress, FormatRate) {
  EXPECT_EQ(FormatRate(12.34), "12.3 it/s");
  EXPECT_EQ(FormatRate(1234.5), "1234 it/s");
  EXPECT_EQ(FormatRate(0.25), "4.0 s/it");
  EXPECT_EQ(FormatRate(0), "-- it/s");
}

TEST(Progress, BarLineWithEta) {
  // 45 of 100 in 3.6 s: 12.5 it/s, 55 left -> 4.4 s -> "0:04".
  EXPECT_EQ(FormatProgressLine("render", 45, 100, 3.6, "loss 0.12", 20),
            "render [#########...........] 45/100 45% 12.5 it/s ETA 0:04 loss 0.12");
  EXPECT_EQ(FormatProgressLine("fit", 0, 10, 0.0, "", 10), "fit [..........] 0/10 0% -- it/s ETA --:--");
  EXPECT_EQ(FormatProgressLine("fit", 10, 10, 8.0, "", 10, true),
            "fit [##########] 10/10 100% 1.2 it/s in 0:08");
  // More than the total (a caller bug) does not overflow the bar.
  EXPECT_EQ(FormatProgressLine("x", 12, 10, 1.0, "", 4), "x [####] 12/10 100% 12.0 it/s ETA 0:00");
}

TEST(Progress, PlainAndUnknownTotalLines) {
  EXPECT_EQ(FormatProgressLine("render", 30, 100, 60.0, "", 0),
            "render 30/100 30% 2.0 s/it ETA 2:20");
  EXPECT_EQ(FormatProgressLine("scan", 7, 0, 2.0, "ok", 20), "scan 7 3.5 it/s elapsed 0:02 ok");
  EXPECT_EQ(FormatProgressLine("scan", 7, 0, 2.0, "", 20, true), "scan 7 3.5 it/s in 0:02");
}

TEST(Progress, PlainModePrintsOneLinePerTenPercent) {
  testing::internal::CaptureStderr();
  {
    Progress progress("work", 1000, Progress::Mode::kPlain);
    for (int i = 0; i < 1000; ++i) progress.Advance();
    progress.SetStatus("done");
  }
  const std::vector<std::string> lines = Lines(testing::internal::GetCapturedStderr());
  ASSERT_EQ(lines.size(), 10u);
  EXPECT_EQ(lines[0].rfind("work 100/1000 10%", 0), 0u) << lines[0];
  EXPECT_EQ(lines[9].rfind("work 1000/1000 100%", 0), 0u) << lines[9];
  EXPECT_NE(lines[9].find(" in "), std::string::npos) << lines[9];
}

TEST(Progress, PlainModeEarlyFinishAndThreads) {
  testing::internal::CaptureStderr();
  Progress progress("jobs", 400, Progress::Mode::kPlain);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 50; ++i) progress.Advance();
    });
  }
  for (std::thread& thread : threads) thread.join();
  progress.Finish();
  progress.Finish();    // idempotent
  progress.Advance(5);  // after Finish: counted, not printed
  const std::vector<std::string> lines = Lines(testing::internal::GetCapturedStderr());
  EXPECT_EQ(progress.done(), 205);
  ASSERT_EQ(lines.size(), 6u);  // 10%..50%, then the final line
  EXPECT_EQ(lines.back().rfind("jobs 200/400 50%", 0), 0u) << lines.back();
  EXPECT_NE(lines.back().find(" in "), std::string::npos);
}

TEST(Progress, TtyModeRedrawsInPlaceAndEndsWithNewline) {
  testing::internal::CaptureStderr();
  {
    Progress progress("tty", 3, Progress::Mode::kTty);
    progress.Advance(3);
  }
  const std::string out = testing::internal::GetCapturedStderr();
  // The initial draw and the final line; Advance() within 200 ms is skipped.
  EXPECT_EQ(out.rfind("\rtty [....................] 0/3 0%", 0), 0u) << out;
  EXPECT_NE(out.find("\rtty [####################] 3/3 100%"), std::string::npos) << out;
  EXPECT_EQ(out.back(), '\n');
  EXPECT_EQ(Lines(out).size(), 1u);
}

TEST(Progress, EnvironmentSelectsMode) {
  const char* saved = std::getenv("RELIT_PROGRESS");
  const std::string saved_value = saved ? saved : "";
  setenv("RELIT_PROGRESS", "0", 1);
  EXPECT_EQ(Progress::DefaultMode(), Progress::Mode::kSilent);
  testing::internal::CaptureStderr();
  {
    Progress progress("quiet", 10);
    progress.Advance(10);
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  setenv("RELIT_PROGRESS", "1", 1);
  EXPECT_EQ(Progress::DefaultMode(), Progress::Mode::kTty);
  unsetenv("RELIT_PROGRESS");
  // Test runs have stderr redirected or on a terminal; either way not silent.
  EXPECT_NE(Progress::DefaultMode(), Progress::Mode::kSilent);
  if (saved) setenv("RELIT_PROGRESS", saved_value.c_str(), 1);
}

TEST(Progress, StderrLockClearsAndRedrawsBar) {
  testing::internal::CaptureStderr();
  {
    Progress progress("bar", 10, Progress::Mode::kTty);
    {
      internal::StderrLock lock;
      std::fputs("message\n", stderr);
    }
  }
  const std::string out = testing::internal::GetCapturedStderr();
  const size_t message = out.find("\r\033[Kmessage\n\rbar [");
  EXPECT_NE(message, std::string::npos) << out;
}

}  // namespace
}  // namespace relit
