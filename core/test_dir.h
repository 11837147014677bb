// For the tests only: a fresh folder per test, named after the test and the
// process (tests of one binary may run in parallel with other binaries'),
// removed when the test ends; and whole-file text helpers.
#pragma once

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

namespace relit::test_support {

inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream stream(path);
  std::ostringstream text;
  text << stream.rdbuf();
  return text.str();
}

inline void WriteText(const std::filesystem::path& path, const std::string& text) { std::ofstream(path) << text; }

class TempDirTest : public ::testing::Test {
 protected:
  // `prefix` names the test file's folders ("relit_atomic_").
  explicit TempDirTest(std::string prefix) : prefix_(std::move(prefix)) {}

  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            (prefix_ + std::string(info->name()) + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  std::filesystem::path root_;

 private:
  std::string prefix_;
};

}  // namespace relit::test_support
