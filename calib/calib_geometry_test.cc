// The geometry pass through calib and into reconstruct: relit-synth renders
// the tiny spot capture with --geometry-pass, relit-capture ingests all three
// videos, relit-calib registers the geometry-pass frames (board detection,
// phone V's lens, COLMAP, joint refinement) and relit-reconstruct builds its
// dense proxy from them. Poses are compared with truth.json, the proxy with
// the GT mesh.
//
// RELIT_CALIB_TEST_GEOMETRY_SYNTH=DIR reuses an existing `relit-synth --preset
// spot --size tiny --seed 1 --geometry-pass` render instead of rendering one.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include <gtest/gtest.h>
#include <unistd.h>

#include "calib/calib.h"
#include "calib/synth_capture_test_util.h"
#include "calib/capture_file.h"
#include "calib/truth_accuracy.h"
#include "capture/capture.h"
#include "core/error.h"
#include "core/json_file.h"
#include "core/render/mesh.h"
#include "core/workspace.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/reconstruct.h"
#include "tools/synth/synth.h"
#include "tools/synth/truth.h"

namespace relit::calib {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class CalibGeometryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relit_calib_geometry_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    synth_ = dir_ / "synth";
    if (const char* reuse = std::getenv("RELIT_CALIB_TEST_GEOMETRY_SYNTH")) {
      synth_ = reuse;
    } else {
      synth::SynthOptions o = synth::SynthOptions::ForSize("tiny");
      o.preset = "spot";
      o.seed = 1;
      o.geometry_pass = true;
      o.out = synth_.string();
      o.eval_views = 1;  // neither calib nor reconstruct reads the evaluation set
      o.eval_samples_per_pixel = 1;
      synth::RunSynthImpl(o);
    }
    truth_ = ReadJsonFile((synth_ / "truth.json").string(), synth::kTruthKind, synth::kTruthVersion);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_, synth_;
  json truth_;
};

TEST_F(CalibGeometryTest, GeometryPassIsRegisteredAndFeedsTheProxy) {
  const std::string ws = (dir_ / "ws").string();
  capture::CaptureOptions c = testing::SynthCaptureOptions(synth_, ws + "/capture");
  c.geometry = (synth_ / "geometry.mp4").string();
  c.geometry_select.target_frames = 15;  // every other frame of the turn: keeps COLMAP's share of the test short
  capture::RunCaptureImpl(c);
  const json capture = ReadJsonFile(c.out + "/capture.json", "capture", 1);
  const int geometry_frames = static_cast<int>(capture["geometry_frames"].size());
  ASSERT_GE(geometry_frames, 12);

  CalibOptions o;
  o.workspace = ws;
  o.board = BoardSpecFromTruth(truth_);
  o.light.flash_offset_m = TruthFlashOffset(truth_);
  o.sfm.sequential_overlap = 6;
  RunCalibImpl(o);

  // Poses of the geometry-pass frames against the truth.
  const CalibAccuracy accuracy = MeasureCalibAccuracy(ws, truth_);
  std::cout << "accuracy: " << accuracy.Summary() << "\n";
  ASSERT_TRUE(accuracy.devices.count("geometry"));
  const DeviceAccuracy& g = accuracy.devices.at("geometry");
  // Measured: 15 frames median 1.5 mm / 0.28 deg (p90 1.7 mm / 0.32 deg),
  // focal -0.28%; all 30 frames of the pass 2.1 mm / 0.31 deg (p90 2.9 mm /
  // 0.50 deg). COLMAP varies from run to run, hence the margin.
  EXPECT_GE(g.frames, geometry_frames - 1);
  EXPECT_LE(g.position_median_mm, 4.0);
  EXPECT_LE(g.rotation_median_deg, 0.6);
  EXPECT_LE(g.position_p90_mm, 6.0);
  EXPECT_LE(std::abs(g.focal_error), 0.0125);
  // Phone V and L stay as accurate as without the pass (calib_synth_test).
  EXPECT_LE(accuracy.devices.at("view").position_median_mm, 5.0);
  EXPECT_LE(accuracy.flash_median_mm, 12.5);

  const json report = ReadJsonFile(ws + "/calib/calib_report.json", "calib_report", 1);
  std::cout << "geometry report: " << report["geometry"].dump() << "\n";
  EXPECT_EQ(report["geometry"]["frames"], geometry_frames);
  EXPECT_EQ(report["geometry"]["registered"], g.frames);
  EXPECT_EQ(report["registered"]["geometry"], g.frames);
  EXPECT_GT(report["geometry"]["registered_by_sfm"].get<int>(), geometry_frames / 2);
  EXPECT_LT(report["geometry"]["corner_rms_px"].get<double>(), 0.75);  // measured 0.49-0.50
  EXPECT_EQ(report["detection"]["geometry"]["frames"], geometry_frames);

  const CamerasFile cameras = ReadCamerasFile(ws + "/calib/cameras.json");
  ASSERT_TRUE(cameras.devices.count("geometry"));
  EXPECT_EQ(cameras.devices.at("geometry").fx, cameras.devices.at("view").fx);  // one phone, one lens
  for (const CalibratedFrame* f : cameras.FramesOf("geometry")) {
    EXPECT_TRUE(f->image_linear.empty()) << f->name;
    EXPECT_TRUE(fs::exists(ws + "/" + f->image_8bit)) << f->image_8bit;
  }
  const LightsFile lights = ReadLightsFile(ws + "/calib/lights.json");
  for (const FrameLight& l : lights.frames) EXPECT_EQ(l.view_frame.rfind("view/", 0), 0u) << l.view_frame;

  // reconstruct takes its proxy from the geometry-pass frames.
  reconstruct::ReconstructOptions r;
  r.workspace = ws;
  r.max_matte_frames = 2;
  r.proxy.sparse_fallback = false;
  reconstruct::RunReconstructImpl(r);
  const json rr = ReadJsonFile(ws + "/reconstruct/reconstruct_report.json", "reconstruct_report", 1);
  EXPECT_EQ(rr["proxy"]["input_frames"]["device"], "geometry");
  EXPECT_EQ(rr["proxy"]["input_frames"]["count"], g.frames);
  const ProxyFile proxy = ReadProxyFile(ws + "/reconstruct/proxy.json");
  const render::TriangleMesh mesh = render::LoadMesh(ws + "/" + proxy.mesh);
  const render::TriangleMesh truth_mesh = render::LoadMesh((synth_ / truth_["objects"][0]["mesh"].get<std::string>()).string());
  const double diagonal = truth_mesh.Bounds().diagonal().norm();
  const double chamfer = reconstruct::SymmetricChamferDistance(mesh, truth_mesh, 20000);
  const reconstruct::MeshStats stats = reconstruct::AnalyseMesh(mesh);
  std::cout << "proxy from the calibrated geometry pass: Chamfer " << chamfer * 1e3 << " mm = "
            << 100 * chamfer / diagonal << "% of the GT bbox diagonal, " << stats.components << " component(s), closed "
            << stats.closed() << ", manifold " << stats.manifold() << "\n";
  // Measured 3.2-4.8 % over 13 runs of the same render (COLMAP's spread), once
  // above 5 % on CI: at 320x240 the legs are 2-4 px wide and no consistent
  // depth survives on them (with or without proxy.edge_margin_px), so the
  // proxy ends at z = 3 cm (truth 0.5 mm). With the depth hull's roof it was
  // 10.4 % (4703111). A leg stump kept apart is a second component (1 of 13),
  // two stumps a third: on 2026-11-29 the cleanup kept 3 of 5 components in 2
  // of 4 runs (COLMAP's spread: the count is settled before any refinement
  // moves a vertex), the test's other figures unchanged (Chamfer 4.8-5.0 %).
  EXPECT_LT(chamfer / diagonal, 0.065);
  EXPECT_LE(stats.components, 3);
  EXPECT_TRUE(stats.closed());
  EXPECT_TRUE(stats.manifold());
}

// capture.json with a folder of geometry-pass photos: no times (file order),
// and photos at another size than phone V's frames are refused.
TEST(CaptureFileGeometry, PhotosAreReadInOrderAndMustMatchPhoneVsSize) {
  const fs::path ws = fs::temp_directory_path() / ("relit_calib_capture_file_" + std::to_string(::getpid()));
  fs::create_directories(ws / "capture");
  auto write = [&](int photo_width) {
    json capture = {
        {"inputs", {{"view", {{"output_width_px", 320}, {"output_height_px", 240}}},
                    {"light", {{"output_width_px", 320}, {"output_height_px", 240}}},
                    {"geometry", {{"type", "photos"}, {"path", "/photos"}, {"photos", 2}}}}},
        {"view_frames", json::array({json{{"index", 0}, {"time_s", 0.1}, {"image", "view/000000.png"},
                                          {"linear", "view_linear/000000.exr"}}})},
        {"light_frames", json::array({json{{"index", 0}, {"time_s", 0.1}, {"image", "light/000000.png"}}})},
        {"geometry_frames", json::array()}};
    for (int i = 0; i < 2; ++i) {
      char image[32];
      std::snprintf(image, sizeof(image), "geometry/%06d.png", i);
      capture["geometry_frames"].push_back({{"index", i}, {"image", image}, {"width_px", photo_width}, {"height_px", 240}});
    }
    WriteJsonFile((ws / "capture" / "capture.json").string(), "capture", 1, capture);
  };
  write(320);
  const CaptureInput input = ReadCaptureFile(ws.string());
  ASSERT_EQ(input.geometry.size(), 2u);
  EXPECT_EQ(input.geometry[1].name, "geometry/000001");
  EXPECT_EQ(input.geometry[1].device, "geometry");
  EXPECT_EQ(input.geometry[1].time_s, 1.0);
  EXPECT_EQ(input.geometry[1].image, "capture/geometry/000001.png");
  write(640);
  try {
    ReadCaptureFile(ws.string());
    ADD_FAILURE() << "photos at another size were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("phone V's lens"), std::string::npos) << e.what();
  }
  fs::remove_all(ws);
}

}  // namespace
}  // namespace relit::calib
