// Phone L's frames as views for the photometric refinement: undistorted with
// phone L's calibrated lens, at the poses calib registered.
#include "reconstruct/light_views.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/capture_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_file.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

class LightViewsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relit_light_views_" + std::to_string(::getpid()));
    fs::create_directories(dir_ / "capture" / "light");
    lens_.width = 80;
    lens_.height = 60;
    lens_.fx = lens_.fy = 60;
    lens_.cx = 39.5;
    lens_.cy = 29.5;
    lens_.distortion.k1 = 0.6;  // strong: the corners move by several pixels
    cameras_.devices["light"] = lens_;
    for (const char* name : {"light/000000", "light/000001"}) {
      CalibratedFrame frame;
      frame.name = name;
      frame.device = "light";
      frame.cam_from_world = Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.01, -0.02, 0.5));
      cameras_.frames.push_back(frame);
    }
  }
  void TearDown() override { fs::remove_all(dir_); }

  // capture.json lists light/000000 only (light/000001 has a pose, no image).
  void WriteCapture(int image_width) {
    const nlohmann::json capture = nlohmann::json::parse(R"({
      "inputs": {"view": {"output_width_px": 64, "output_height_px": 48, "transfer_used": "srgb"},
                 "light": {"output_width_px": 80, "output_height_px": 60}},
      "sync": {"method": "manual", "offset_s": 0.0},
      "view_frames": [{"index": 0, "time_s": 0.0, "image": "view/000000.png"}],
      "light_frames": [{"index": 0, "time_s": 0.0, "image": "light/000000.png"}]
    })");
    WriteJsonFile(CaptureFilePath(dir_.string()), CaptureFile::kKind, CaptureFile::kVersion, capture);
    // A bright dot where `point_` lands through the distorted lens.
    Eigen::Vector2d dot;
    ASSERT_TRUE(Camera(lens_, cameras_.frames[0].cam_from_world).Project(point_, &dot));
    Image image(image_width, lens_.height, 3);
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        const double r2 = (Eigen::Vector2d(x, y) - dot).squaredNorm();
        for (int c = 0; c < 3; ++c) image.at(x, y, c) = static_cast<float>(std::exp(-r2 / 2.0));
      }
    }
    WriteImage((dir_ / "capture" / "light" / "000000.png").string(), image, PixelStorage::kUint8);
  }

  fs::path dir_;
  Intrinsics lens_;
  CamerasFile cameras_;
  const Eigen::Vector3d point_ = Eigen::Vector3d(0.2, 0.13, 0.0);  // near the image's corner
};

TEST_F(LightViewsTest, UndistortsEachImagedFrameAtItsPose) {
  WriteCapture(lens_.width);
  const LightViews views = LoadLightViews(dir_, cameras_);
  ASSERT_EQ(views.cameras.size(), 1u);  // light/000001 has no image
  ASSERT_EQ(views.grays.size(), 1u);
  EXPECT_EQ(views.cameras[0].intrinsics().distortion.k1, 0.0);
  // The dot's centroid in the undistorted frame is where the pinhole camera
  // projects the point.
  Eigen::Vector2d expected, sum = Eigen::Vector2d::Zero();
  ASSERT_TRUE(views.cameras[0].Project(point_, &expected));
  double mass = 0;
  for (int y = 0; y < views.grays[0].rows; ++y) {
    for (int x = 0; x < views.grays[0].cols; ++x) {
      const double w = views.grays[0].at<uint8_t>(y, x) > 40 ? views.grays[0].at<uint8_t>(y, x) : 0.0;
      sum += w * Eigen::Vector2d(x, y);
      mass += w;
    }
  }
  ASSERT_GT(mass, 0);
  Eigen::Vector2d distorted;
  ASSERT_TRUE(Camera(lens_, cameras_.frames[0].cam_from_world).Project(point_, &distorted));
  ASSERT_GT((distorted - expected).norm(), 3.0);  // the lens moves it: the test can tell
  EXPECT_LT((sum / mass - expected).norm(), 0.3);
}

TEST_F(LightViewsTest, NoCaptureFileMeansNoViews) {
  EXPECT_TRUE(LoadLightViews(dir_, cameras_).cameras.empty());
}

TEST_F(LightViewsTest, AnImageOfAnotherSizeIsAnErrorNamingIt) {
  WriteCapture(lens_.width + 2);
  try {
    LoadLightViews(dir_, cameras_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("000000.png"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace relit::reconstruct
