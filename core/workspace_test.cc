#include "core/workspace.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/test_dir.h"

namespace relit {
namespace {

std::string TempPath(const std::string& name) { return test_support::TempPathIn("relit_workspace_test", name); }

TEST(Workspace, CamerasRoundTrip) {
  CamerasFile file;
  file.devices["view"] = Intrinsics::FromFov(320, 240, 1.1);
  file.devices["view"].distortion.k1 = 0.1;
  file.devices["light"] = Intrinsics::FromFov(320, 240, 1.2);
  file.undistorted_view = file.devices["view"].WithoutDistortion();
  CalibratedFrame frame;
  frame.name = "view/000003";
  frame.device = "view";
  frame.time_s = 0.1;
  frame.cam_from_world = LookAt({0.3, 0.1, 0.4}, {0, 0, 0}, {0, 0, 1});
  frame.image_linear = "calib/undistorted/view/000003.exr";
  frame.image_8bit = "calib/undistorted/view/000003.png";
  file.frames.push_back(frame);
  const std::string path = TempPath("cameras.json");
  WriteCamerasFile(path, file);
  const CamerasFile back = ReadCamerasFile(path);
  ASSERT_EQ(back.frames.size(), 1u);
  EXPECT_EQ(back.frames[0].name, "view/000003");
  EXPECT_NEAR(back.devices.at("view").distortion.k1, 0.1, 1e-12);
  EXPECT_LT((back.frames[0].cam_from_world.translation - frame.cam_from_world.translation).norm(), 1e-12);
  EXPECT_EQ(back.FramesOf("view").size(), 1u);
  EXPECT_EQ(back.FramesOf("light").size(), 0u);
  EXPECT_NE(back.Find("view/000003"), nullptr);
  EXPECT_EQ(back.board.squares_x, file.board.squares_x);
}

TEST(Workspace, LightsAndProxyRoundTrip) {
  LightsFile lights;
  lights.flash_offset_m = {0.01, 0, 0};
  lights.frames.push_back({"view/000001", 0.5, {0.1, 0.2, 0.3}, 0.02, false});
  WriteLightsFile(TempPath("lights.json"), lights);
  const LightsFile lights_back = ReadLightsFile(TempPath("lights.json"));
  ASSERT_NE(lights_back.Find("view/000001"), nullptr);
  EXPECT_FALSE(lights_back.Find("view/000001")->reliable);
  EXPECT_NEAR(lights_back.frames[0].position_m.z(), 0.3, 1e-12);

  ProxyFile proxy;
  proxy.mesh = "reconstruct/proxy.obj";
  proxy.object_radius_m = 0.1;
  proxy.mattes.push_back({"view/000001", "reconstruct/mattes/000001.png", "reconstruct/trimaps/000001.png"});
  WriteProxyFile(TempPath("proxy.json"), proxy);
  const ProxyFile proxy_back = ReadProxyFile(TempPath("proxy.json"));
  EXPECT_EQ(proxy_back.mesh, proxy.mesh);
  EXPECT_EQ(proxy_back.Find("view/000001")->trimap, "reconstruct/trimaps/000001.png");
  EXPECT_EQ(proxy_back.normal_map, "");  // optional: absent when there is none
  proxy.normal_map = "reconstruct/proxy_normals.exr";
  WriteProxyFile(TempPath("proxy.json"), proxy);
  EXPECT_EQ(ReadProxyFile(TempPath("proxy.json")).normal_map, proxy.normal_map);
}

TEST(Workspace, FrameOfUnknownDeviceIsRejected) {
  const std::string path = TempPath("bad_cameras.json");
  CamerasFile file;
  file.devices["view"] = Intrinsics::FromFov(32, 24, 1.0);
  file.undistorted_view = file.devices["view"];
  CalibratedFrame frame;
  frame.name = "x";
  frame.device = "drone";
  file.frames.push_back(frame);
  WriteCamerasFile(path, file);
  try {
    ReadCamerasFile(path);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("drone"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("bad_cameras.json"), std::string::npos);
  }
}

}  // namespace
}  // namespace relit
