// For the tests only: a fresh folder per test, named after the test and the
// process (tests of one binary may run in parallel with other binaries'),
// removed when the test ends; a path in a folder kept for a test file; a
// cache shared by a test binary's processes; and whole-file text helpers.
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

// `name` in the folder one test file shares ("relit_image_test"), made if
// missing and kept after the run.
inline std::string TempPathIn(const std::string& folder, const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / folder;
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A folder that a test binary's processes share (CTest runs each test in
// a process of its own), <tmp>/<prefix><uid>, and a key naming this build of
// the binary (its size and modification time): what a test renders once is
// kept under a name with the key, and a rebuilt binary renders afresh.
struct BuildCache {
  std::filesystem::path dir;
  std::string build_key;
};

inline BuildCache TestBuildCache(const std::string& prefix) {
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe");
  const auto stamp = std::filesystem::last_write_time(exe).time_since_epoch().count();
  BuildCache cache{std::filesystem::temp_directory_path() / (prefix + std::to_string(::getuid())),
                   std::to_string(std::filesystem::file_size(exe)) + "_" + std::to_string(stamp)};
  std::filesystem::create_directories(cache.dir);
  return cache;
}

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
