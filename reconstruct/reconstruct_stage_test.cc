// The reconstruct stage end to end on a synthetic workspace (tiny spot
// capture rendered with pinhole cameras), plus matting and option checks.
#include <filesystem>
#include <iostream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/image.h"
#include "core/options.h"
#include "core/render/scene.h"
#include "core/workspace.h"
#include "reconstruct/closed_form_matting.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/reconstruct.h"
#include "reconstruct/test_workspace.h"
#include "reconstruct/trimap.h"

namespace relit::reconstruct {
namespace {

namespace fs = std::filesystem;

const testing::TestWorkspace& Workspace() { return testing::SharedTestWorkspace("reconstruct_stage_ws", 6, 16); }

TEST(ClosedFormMatting, RecoversASoftEdgeBetweenTwoColours) {
  const int w = 64, h = 48;
  cv::Mat image(h, w, CV_32FC3), truth(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float a = std::clamp((x - 28.0f + 0.3f * y) / 6.0f, 0.0f, 1.0f);
      const cv::Vec3f fg(0.9f, 0.3f, 0.2f), bg(0.1f + 0.002f * y, 0.4f, 0.8f);
      image.at<cv::Vec3f>(y, x) = a * fg + (1 - a) * bg;
      truth.at<float>(y, x) = a;
    }
  }
  cv::Mat trimap(h, w, CV_8U, cv::Scalar(kTrimapUnknown));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (truth.at<float>(y, x) == 0 && x < 20) trimap.at<uint8_t>(y, x) = kTrimapBackground;
      if (truth.at<float>(y, x) == 1 && x > 44) trimap.at<uint8_t>(y, x) = kTrimapForeground;
    }
  }
  MatteStats stats;
  const cv::Mat alpha = SolveClosedFormMatte(image, trimap, cv::Mat(), MattingOptions{}, &stats);
  EXPECT_GT(stats.unknown_px, 0);
  const double mse = testing::MatteMse(alpha, truth);
  EXPECT_LT(mse, 1e-4) << "MSE " << mse;
  // No unknown band: a clear error.
  try {
    SolveClosedFormMatte(image, cv::Mat(h, w, CV_8U, cv::Scalar(kTrimapForeground)), cv::Mat(), MattingOptions{},
                         &stats);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no unknown band"), std::string::npos) << e.what();
  }
}

TEST(ClosedFormMatting, MultiScaleAgreesWithSingleScale) {
  const int w = 128, h = 96;
  cv::Mat image(h, w, CV_32FC3), truth(h, w, CV_32F);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float r = std::hypot(x - 64.0f, y - 48.0f);
      const float a = std::clamp((30.0f - r) / 3.0f, 0.0f, 1.0f);
      image.at<cv::Vec3f>(y, x) = a * cv::Vec3f(0.8f, 0.7f, 0.1f) + (1 - a) * cv::Vec3f(0.1f, 0.2f, 0.5f);
      truth.at<float>(y, x) = a;
    }
  }
  cv::Mat silhouette = (truth > 0.5f);
  const cv::Mat trimap = MakeTrimap(silhouette, 5);
  MattingOptions single, multi;
  multi.multiscale_min_megapixels = 0.005;
  MatteStats s1, s2;
  const cv::Mat a1 = SolveClosedFormMatte(image, trimap, cv::Mat(), single, &s1);
  const cv::Mat a2 = SolveClosedFormMatte(image, trimap, cv::Mat(), multi, &s2);
  EXPECT_EQ(s1.levels, 1);
  EXPECT_GE(s2.levels, 2);
  EXPECT_LT(s2.unknown_px, s1.unknown_px);
  EXPECT_LT(testing::MatteMse(a1, truth), 1e-4);
  EXPECT_LT(testing::MatteMse(a2, truth), 1e-3);
}

TEST(ReconstructOptions, UnknownKeysAndBadValuesAreErrors) {
  ReconstructOptions options, typo_options, range_options;
  OptionsReader typo = OptionsReader::FromString("atlas:\n  resolution: 512\n");
  EXPECT_THROW(ReadOptions(typo, &typo_options), Error);
  OptionsReader range = OptionsReader::FromString("cleanup:\n  target_faces: 3\n");
  EXPECT_THROW(ReadOptions(range, &range_options), Error);
  OptionsReader good = OptionsReader::FromString(
      "atlas:\n  resolution_px: 1024\nmatting:\n  epsilon: 1.0e-6\nproxy:\n  photo: {views: 6}\n"
      "  hull: {enabled: false, voxel_m: 0.003}\n");
  ReadOptions(good, &options);
  EXPECT_EQ(options.atlas.resolution_px, 1024);
  EXPECT_EQ(options.proxy.photo.views, 6);
  EXPECT_FALSE(options.proxy.hull.enabled);
  EXPECT_EQ(options.proxy.hull.voxel_m, 0.003);
  options.workspace = "w";
  EXPECT_NO_THROW(CheckOptions(options));
  const nlohmann::json json = OptionsToJson(options);
  EXPECT_EQ(json["atlas"]["resolution_px"], 1024);
  EXPECT_EQ(json["proxy"]["hull"]["voxel_m"], 0.003);
  EXPECT_EQ(options.proxy.method, "dense");
  ReconstructOptions proxy_typo, proxy_bad, with_mesh;
  OptionsReader typo2 = OptionsReader::FromString("proxy:\n  neighbors: 2\n");
  EXPECT_THROW(ReadOptions(typo2, &proxy_typo), Error);
  OptionsReader bad = OptionsReader::FromString("proxy:\n  method: mvs\n");
  EXPECT_THROW(ReadOptions(bad, &proxy_bad), Error);
  proxy_bad.workspace = "w";
  proxy_bad.proxy.method = "mvs";
  EXPECT_THROW(CheckOptions(proxy_bad), Error);
  OptionsReader mesh_only = OptionsReader::FromString("mesh: scan.obj\n");
  ReadOptions(mesh_only, &with_mesh);
  EXPECT_EQ(with_mesh.proxy.method, "mesh");  // a mesh alone selects it
}

// Every flat photo_*/hull_* key of before the proxy.photo/proxy.hull
// sections is refused with one line that names its new key.
TEST(ReconstructOptions, MovedProxyKeysNameTheirNewKey) {
  const std::vector<std::pair<std::string, std::string>> moved = {
      {"photo_refine", "photo.enabled"},
      {"photo_views", "photo.views"},
      {"photo_max_baseline_deg", "photo.max_baseline_deg"},
      {"photo_window_radius_px", "photo.window_radius_px"},
      {"photo_search_fraction", "photo.search_fraction"},
      {"photo_search_steps", "photo.search_steps"},
      {"photo_min_texture", "photo.min_texture"},
      {"photo_min_score", "photo.min_score"},
      {"photo_color_sigma", "photo.color_sigma"},
      {"hull_points", "hull.enabled"},
      {"hull_voxel_m", "hull.voxel_m"},
      {"hull_min_free_views", "hull.min_free_views"},
      {"hull_free_tolerance", "hull.free_tolerance"},
      {"hull_margin_fraction", "hull.margin_fraction"},
      {"hull_point_gap", "hull.point_gap"},
      {"hull_contact_height_m", "hull.contact_height_m"},
      {"hull_contact_radius_m", "hull.contact_radius_m"},
      {"hull_max_open_border", "hull.max_open_border"}};
  for (const auto& [old_key, new_key] : moved) {
    OptionsReader reader = OptionsReader::FromString("proxy:\n  method: dense\n  " + old_key + ": 1\n", "r.yaml");
    ReconstructOptions options;
    try {
      ReadOptions(reader, &options);
      ADD_FAILURE() << old_key << " was accepted";
    } catch (const Error& e) {
      const std::string expected =
          "r.yaml:3:" + std::to_string(5 + old_key.size()) + " key 'proxy." + old_key + "': moved to 'proxy." + new_key + "'";
      EXPECT_EQ(std::string(e.what()), expected);
    }
    // The new key is read (with its default value, as JSON text).
    const std::string section = new_key.substr(0, new_key.find('.'));
    const std::string key = new_key.substr(new_key.find('.') + 1);
    const std::string value = OptionsToJson(ProxyOptions())[section][key].dump();
    OptionsReader now =
        OptionsReader::FromString("proxy:\n  " + section + ":\n    " + key + ": " + value + "\n", "r.yaml");
    EXPECT_NO_THROW(ReadOptions(now, &options)) << new_key;
  }
}

TEST(Reconstruct, UserMeshToProxyAtlasAndMattes) {
  const testing::TestWorkspace& ws = Workspace();
  ReconstructOptions options;
  options.workspace = ws.dir;
  // A rough proxy: the object inflated by 3 mm (Poisson/stereo-like), so the
  // projected silhouette is off by ~2 px and the matte has work to do.
  options.mesh = ws.rough_mesh;
  options.proxy.method = "mesh";
  const ReconstructSummary summary = RunReconstructImpl(options);
  EXPECT_EQ(summary.mattes, static_cast<int>(ws.cameras.frames.size()));
  const fs::path out = fs::path(ws.dir) / "reconstruct";
  for (const char* file : {"proxy.obj", "proxy.mtl", "proxy.json", "atlas_preview.png", "reconstruct_report.json",
                           "reconstruct.log", "run.json"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  const ProxyFile proxy = ReadProxyFile((out / "proxy.json").string());
  const render::TriangleMesh mesh = render::LoadMesh((fs::path(ws.dir) / proxy.mesh).string());
  EXPECT_TRUE(mesh.has_uvs());
  const MeshStats stats = AnalyseMesh(mesh);
  EXPECT_TRUE(stats.closed());
  EXPECT_TRUE(stats.manifold());
  EXPECT_EQ(stats.components, 1);
  EXPECT_GT(stats.volume_m3, 0);
  for (const Eigen::Vector3f& p : mesh.positions) ASSERT_GT(p.z(), 0.0f);  // no board triangles
  const double diagonal = ws.truth_mesh.Bounds().diagonal().norm();
  const double chamfer = SymmetricChamferDistance(mesh, ws.truth_mesh, 10000);
  std::cout << "proxy vs GT: Chamfer " << 100 * chamfer / diagonal << "% of the bbox diagonal\n";
  EXPECT_LT(chamfer / diagonal, 0.05);
  EXPECT_GT(proxy.object_radius_m, 0.03);

  // Mattes vs GT alpha, against the binary projected silhouette.
  render::Scene scene;
  scene.AddObject(mesh, render::Material::Lambert(render::Rgb::Constant(0.5f)), 1);
  scene.Commit();
  double mse_matte = 0, mse_binary = 0, sad_matte = 0, sad_binary = 0;
  ASSERT_EQ(proxy.mattes.size(), ws.cameras.frames.size());
  for (size_t i = 0; i < ws.cameras.frames.size(); ++i) {
    const CalibratedFrame& frame = ws.cameras.frames[i];
    const ViewMatte* vm = proxy.Find(frame.name);
    ASSERT_NE(vm, nullptr) << frame.name;
    const cv::Mat matte = ReadImage((fs::path(ws.dir) / vm->matte).string()).ToMat();
    const cv::Mat trimap = ReadImage((fs::path(ws.dir) / vm->trimap).string()).ToMat();
    ASSERT_EQ(matte.size(), ws.truth_alpha[i].size());
    cv::Mat trimap_8u;
    trimap.convertTo(trimap_8u, CV_8U, 255.0);
    EXPECT_GT(cv::countNonZero(trimap_8u == kTrimapUnknown), 0);
    cv::Mat binary;
    ProjectSilhouette(scene, ws.cameras.ViewCamera(frame)).convertTo(binary, CV_32F, 1.0 / 255.0);
    const double m = testing::MatteMse(matte, ws.truth_alpha[i]), b = testing::MatteMse(binary, ws.truth_alpha[i]);
    std::cout << frame.name << ": matte MSE " << m << " SAD " << testing::MatteSad(matte, ws.truth_alpha[i])
              << ", binary MSE " << b << " SAD " << testing::MatteSad(binary, ws.truth_alpha[i]) << "\n";
    mse_matte += m;
    mse_binary += b;
    sad_matte += testing::MatteSad(matte, ws.truth_alpha[i]);
    sad_binary += testing::MatteSad(binary, ws.truth_alpha[i]);
  }
  std::cout << "total: matte MSE " << mse_matte << " SAD " << sad_matte << "; binary MSE " << mse_binary << " SAD "
            << sad_binary << "; ratio " << mse_binary / mse_matte << "\n";
  EXPECT_LT(2.0 * mse_matte, mse_binary);
}

TEST(Reconstruct, BadInputsAreClearErrors) {
  const testing::TestWorkspace& ws = Workspace();
  ReconstructOptions options;
  options.workspace = ws.dir;
  options.proxy.method = "mesh";
  try {
    RunReconstructImpl(options);  // method mesh without a mesh
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--mesh"), std::string::npos) << e.what();
  }
  const std::string below = ws.dir + "/below.obj";
  render::SaveMesh(below, render::MakeSphere({0, 0, -1.0f}, 0.1f, 8, 4));
  options.mesh = below;
  EXPECT_THROW(RunReconstructImpl(options), Error);
  options.workspace = ws.dir + "/missing";
  EXPECT_THROW(RunReconstructImpl(options), Error);
}

}  // namespace
}  // namespace relit::reconstruct
