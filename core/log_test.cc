#include "core/log.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/main_wrapper.h"

namespace relit {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& path) {
  std::ifstream stream(path);
  std::ostringstream text;
  text << stream.rdbuf();
  return text.str();
}

class LogTest : public testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("relit_log_" + std::to_string(getpid()));
    fs::remove_all(root_);
  }
  // Back to plain stderr logging so other tests do not write into root_.
  void TearDown() override {
    InitLogging();
    fs::remove_all(root_);
  }
  fs::path root_;
};

TEST_F(LogTest, StderrAndFileWithLevels) {
  const fs::path file = root_ / "logs" / "run.log";
  testing::internal::CaptureStderr();
  InitLogging(file.string(), spdlog::level::info);
  spdlog::info("visible {}", 42);
  spdlog::debug("hidden debug");
  SetVerbosity(spdlog::level::debug);
  spdlog::debug("shown debug");
  internal::LogToFileOnly(spdlog::level::err, "file only");
  const std::string err = testing::internal::GetCapturedStderr();
  const std::string log = ReadText(file);

  EXPECT_NE(err.find("visible 42"), std::string::npos) << err;
  EXPECT_NE(err.find("shown debug"), std::string::npos) << err;
  EXPECT_EQ(err.find("hidden debug"), std::string::npos) << err;
  EXPECT_EQ(err.find("file only"), std::string::npos) << err;
  EXPECT_EQ(err.find("\033["), std::string::npos) << "colour codes outside a terminal";

  EXPECT_NE(log.find("[info] "), std::string::npos) << log;
  EXPECT_NE(log.find("visible 42"), std::string::npos) << log;
  EXPECT_NE(log.find("shown debug"), std::string::npos) << log;
  EXPECT_EQ(log.find("hidden debug"), std::string::npos) << log;
  EXPECT_NE(log.find("[error] "), std::string::npos) << log;
  EXPECT_NE(log.find("file only"), std::string::npos) << log;
}

TEST_F(LogTest, FatalErrorReachesLogFile) {
  const fs::path file = root_ / "fatal.log";
  InitLogging(file.string());
  testing::internal::CaptureStderr();
  const int code = internal::ReportFatalError("frame 3 is missing");
  testing::internal::GetCapturedStderr();
  EXPECT_EQ(code, 1);
  EXPECT_NE(ReadText(file).find("error: frame 3 is missing"), std::string::npos);
}

TEST_F(LogTest, UnwritableLogFileIsAnError) {
  fs::create_directories(root_);
  std::ofstream(root_ / "blocker") << "x";
  EXPECT_THROW(InitLogging((root_ / "blocker" / "run.log").string()), Error);
}

TEST_F(LogTest, LogFileScopeDetachesTheFileWhenItEnds) {
  const fs::path file = root_ / "stage.log";
  testing::internal::CaptureStderr();
  {
    LogFileScope scope(file.string(), spdlog::level::info);
    spdlog::info("inside the scope");
  }
  spdlog::info("after the scope");
  testing::internal::GetCapturedStderr();
  const std::string log = ReadText(file);
  EXPECT_NE(log.find("inside the scope"), std::string::npos) << log;
  EXPECT_EQ(log.find("after the scope"), std::string::npos) << log;
}

TEST(LogLevel, Parse) {
  EXPECT_EQ(ParseLogLevel("debug"), spdlog::level::debug);
  EXPECT_EQ(ParseLogLevel("error"), spdlog::level::err);
  EXPECT_THROW(ParseLogLevel("loud"), Error);
}

}  // namespace
}  // namespace relit
