#include "core/run_record.h"

#include <filesystem>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/json_file.h"

namespace relit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(RunRecord, WritesSchemaFieldsAndTimings) {
  const fs::path path =
      fs::temp_directory_path() / ("relit_run_" + std::to_string(getpid())) / "run.json";
  RunRecord record("relight");
  char* argv[] = {const_cast<char*>("relight"), const_cast<char*>("--config=a.yaml")};
  record.SetCommandLine(2, argv);
  record.SetOptions({{"samples", 64}});
  record.AddInput("mesh", "scan/mesh.ply");
  {
    auto timer = record.Time("render");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  {
    auto timer = record.Time("render");  // adds to the same step
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  auto load = record.Time("load");
  const double load_s = load.Stop();
  EXPECT_EQ(load.Stop(), 0.0);  // only recorded once
  record.Set("frames", 12);
  record.Write(path.string());

  const json j = ReadJsonFile(path.string(), "run", 1);
  fs::remove_all(path.parent_path());
  EXPECT_EQ(j["schema"], "relit.run/1");
  EXPECT_EQ(j["tool"], "relight");
  EXPECT_EQ(j["version"], RelitVersion());
  EXPECT_FALSE(std::string(RelitVersion()).empty());
  EXPECT_EQ(j["command_line"], json({"relight", "--config=a.yaml"}));
  EXPECT_EQ(j["options"]["samples"], 64);
  EXPECT_EQ(j["inputs"]["mesh"], "scan/mesh.ply");
  EXPECT_EQ(j["frames"], 12);
  EXPECT_FALSE(j["hostname"].get<std::string>().empty());
  const std::string start = j["start_time_utc"];
  ASSERT_EQ(start.size(), 20u) << start;  // 2024-05-01T12:34:56Z
  EXPECT_EQ(start[10], 'T');
  EXPECT_EQ(start.back(), 'Z');
  const double render_s = j["timings_s"]["render"];
  EXPECT_GE(render_s, 0.039);
  EXPECT_LT(render_s, 0.5);
  EXPECT_DOUBLE_EQ(j["timings_s"]["load"].get<double>(), load_s);
  EXPECT_GE(j["total_s"].get<double>(), render_s);
}

TEST(RunRecord, ReservedKeysAreRejected) {
  RunRecord record("tool");
  EXPECT_THROW(record.Set("timings_s", 1), Error);
  EXPECT_NO_THROW(record.Set("rmse", 0.01));
}

}  // namespace
}  // namespace relit
