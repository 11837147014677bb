#include "core/main_wrapper.h"

#include <cstdlib>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "core/error.h"

namespace relit {
namespace {

char* kArgv[] = {const_cast<char*>("tool"), const_cast<char*>("--flag"), nullptr};

// Runs `body` through RunMain and captures stderr.
template <typename Body>
int RunCaptured(Body body, std::string* err) {
  testing::internal::CaptureStderr();
  const int code = RunMain(2, kArgv, body);
  *err = testing::internal::GetCapturedStderr();
  return code;
}

TEST(MainWrapper, ReturnsRunCodeAndPassesArguments) {
  std::string err;
  EXPECT_EQ(RunCaptured(
                [](int argc, char** argv) {
                  return argc == 2 && std::string(argv[1]) == "--flag" ? 7 : 99;
                },
                &err),
            7);
  EXPECT_EQ(err, "");
}

TEST(MainWrapper, RelitErrorIsOneLine) {
  std::string err;
  const int code = RunCaptured([](int, char**) -> int { Fail("cameras.json: bad\nsecond line\n"); }, &err);
  EXPECT_EQ(code, 1);
  EXPECT_EQ(err, "error: cameras.json: bad; second line\n");
}

TEST(MainWrapper, OtherExceptions) {
  std::string err;
  EXPECT_EQ(RunCaptured([](int, char**) -> int { return YAML::Load("[1").size(); }, &err), 1);
  EXPECT_EQ(err.rfind("error: YAML: ", 0), 0u) << err;
  EXPECT_EQ(RunCaptured([](int, char**) -> int { return nlohmann::json("x").get<int>(); }, &err), 1);
  EXPECT_EQ(err.rfind("error: JSON: [json.exception.type_error", 0), 0u) << err;
  EXPECT_EQ(RunCaptured([](int, char**) -> int { throw std::out_of_range("index 5"); }, &err), 1);
  EXPECT_EQ(err, "error: unexpected: index 5\n");
  EXPECT_EQ(RunCaptured([](int, char**) -> int { throw 42; }, &err), 1);
  EXPECT_EQ(err, "error: unexpected: unknown exception\n");
}

TEST(MainWrapper, SetsQtPlatformOnlyWhenUnset) {
  std::string err;
  unsetenv("QT_QPA_PLATFORM");
  RunCaptured([](int, char**) { return 0; }, &err);
  ASSERT_NE(std::getenv("QT_QPA_PLATFORM"), nullptr);
  EXPECT_STREQ(std::getenv("QT_QPA_PLATFORM"), "offscreen");
  setenv("QT_QPA_PLATFORM", "xcb", 1);
  RunCaptured([](int, char**) { return 0; }, &err);
  EXPECT_STREQ(std::getenv("QT_QPA_PLATFORM"), "xcb");
  unsetenv("QT_QPA_PLATFORM");
}

}  // namespace
}  // namespace relit
