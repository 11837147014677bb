#include "core/capture_file.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/json_file.h"

namespace relit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The fields relit-capture writes that the readers use, as a small file.
json MinimalCapture() {
  return json::parse(R"({
    "inputs": {"view": {"output_width_px": 64, "output_height_px": 48, "transfer_used": "srgb"},
               "light": {"output_width_px": 32, "output_height_px": 24},
               "geometry": {"type": "photos"}},
    "sync": {"method": "manual", "offset_s": 0.25},
    "view_frames": [{"index": 1, "time_s": 0.5, "source_frame": 7, "image": "view/000001.png",
                     "linear": "view_linear/000001.exr", "sharpness": 0.02},
                    {"index": 0, "time_s": 0.0, "source_frame": 3, "image": "view/000000.png",
                     "linear": "view_linear/000000.exr", "sharpness": null}],
    "light_frames": [{"index": 0, "time_s": 0.2, "image": "light/000000.png"}],
    "rejected_view_frames": [{"time_s": 0.3, "sharpness": 0.001, "reason": "blurred"}],
    "geometry_frames": [{"index": 0, "image": "geometry/000000.png", "width_px": 64, "height_px": 48},
                        {"index": 1, "image": "geometry/000001.png", "width_px": 64, "height_px": 48}],
    "counts": {"view": {"kept": 2, "blurred": 1}, "light_usable": 9, "light_kept": 1}
  })");
}

class CaptureFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relit_capture_file_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "capture");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const json& capture) {
    WriteJsonFile(CaptureFilePath(dir_.string()), CaptureFile::kKind, CaptureFile::kVersion, capture);
    return CaptureFilePath(dir_.string());
  }
  fs::path dir_;
};

TEST_F(CaptureFileTest, ReadsTheFieldsTheStagesUse) {
  const CaptureFile file = ReadCaptureFile(Write(MinimalCapture()));
  ASSERT_EQ(file.view.size(), 2u);
  EXPECT_EQ(file.view[0].name, "view/000000");  // index order
  EXPECT_EQ(file.view[0].image, "capture/view/000000.png");
  EXPECT_EQ(file.view[0].linear, "capture/view_linear/000000.exr");
  EXPECT_EQ(file.view[1].source_frame, 7);
  EXPECT_TRUE(std::isnan(file.view[0].sharpness));
  EXPECT_DOUBLE_EQ(file.view[1].sharpness, 0.02);
  ASSERT_EQ(file.light.size(), 1u);
  EXPECT_EQ(file.light[0].source_frame, -1);
  EXPECT_EQ(file.light[0].linear, "");
  ASSERT_EQ(file.geometry.size(), 2u);
  EXPECT_DOUBLE_EQ(file.geometry[1].time_s, 1.0);  // untimed photos: their index
  EXPECT_EQ(file.geometry[1].width_px, 64);
  EXPECT_EQ(file.inputs.at("geometry").type, "photos");
  EXPECT_EQ(file.inputs.at("view").output_width_px, 64);
  EXPECT_EQ(file.inputs.at("view").transfer_used, "srgb");
  EXPECT_EQ(file.inputs.at("light").output_height_px, 24);
  EXPECT_DOUBLE_EQ(file.sync_offset_s, 0.25);
  EXPECT_EQ(file.sync.value("method", ""), "manual");
  ASSERT_EQ(file.rejected_view.size(), 1u);
  EXPECT_EQ(file.rejected_view[0].reason, "blurred");
  EXPECT_EQ(file.view_counts.at("blurred"), 1);
  EXPECT_EQ(file.light_usable, 9);
  EXPECT_EQ(file.light_kept, 1);
  ASSERT_NE(file.Find("light/000000"), nullptr);
  EXPECT_DOUBLE_EQ(file.Find("light/000000")->time_s, 0.2);
  EXPECT_EQ(file.Find("view/000009"), nullptr);
}

TEST_F(CaptureFileTest, OptionalPartsMayBeMissing) {
  json capture = MinimalCapture();
  for (const char* key : {"sync", "rejected_view_frames", "geometry_frames", "counts"}) capture.erase(key);
  const CaptureFile file = ReadCaptureFile(Write(capture));
  EXPECT_DOUBLE_EQ(file.sync_offset_s, 0.0);
  EXPECT_TRUE(file.geometry.empty());
  EXPECT_EQ(file.inputs.count("geometry"), 0u);
  EXPECT_TRUE(file.rejected_view.empty());
  EXPECT_TRUE(file.view_counts.empty());
  EXPECT_FALSE(file.light_usable.has_value());
}

TEST_F(CaptureFileTest, DamagedFilesAreRelitErrors) {
  json unordered = MinimalCapture();
  unordered["view_frames"][0]["time_s"] = -1.0;  // index 1 before index 0
  EXPECT_THROW(ReadCaptureFile(Write(unordered)), Error);
  json no_size = MinimalCapture();
  no_size["inputs"]["light"].erase("output_width_px");
  EXPECT_THROW(ReadCaptureFile(Write(no_size)), Error);
  json wrong_type = MinimalCapture();
  wrong_type["counts"]["light_kept"] = "many";
  EXPECT_THROW(ReadCaptureFile(Write(wrong_type)), Error);
  json wrong_sync = MinimalCapture();
  wrong_sync["sync"]["offset_s"] = json::array();
  EXPECT_THROW(ReadCaptureFile(Write(wrong_sync)), Error);
}

}  // namespace
}  // namespace relit
