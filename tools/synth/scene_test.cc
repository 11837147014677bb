#include "tools/synth/scene.h"

#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

namespace relit::synth {
namespace {

TEST(Scene, PresetsStandOnTheBoard) {
  for (const std::string preset : {"spot", "bunny", "spheres"}) {
    const SynthScene scene = BuildScene(preset, BoardSpec(), DefaultAssetsDir());
    Eigen::AlignedBox3f foreground;
    int boards = 0;
    for (const SynthObject& object : scene.objects) {
      if (object.foreground) foreground.extend(object.mesh.Bounds());
      boards += object.object_id == kBoardObjectId;
      EXPECT_FALSE(object.material_json.empty()) << object.name;
    }
    EXPECT_EQ(boards, 1);
    EXPECT_NEAR(foreground.min().z(), 0.0005, 1e-4) << preset;
    EXPECT_GT(foreground.max().z(), 0.05) << preset;
    EXPECT_LT(foreground.max().z(), 0.15) << preset;
    // The object fits on the 28 x 20 cm board.
    EXPECT_LT(foreground.max().head<2>().cwiseAbs().maxCoeff(), 0.1) << preset;
    EXPECT_LT(foreground.min().head<2>().cwiseAbs().maxCoeff(), 0.1) << preset;
    EXPECT_FALSE(scene.ForegroundIds().empty());
  }
  EXPECT_THROW(BuildScene("teapot", BoardSpec(), DefaultAssetsDir()), std::runtime_error);
}

TEST(Scene, SpotIsTexturedAndGlossy) {
  const SynthScene scene = BuildScene("spot", BoardSpec(), DefaultAssetsDir());
  const SynthObject& spot = scene.objects.front();
  EXPECT_TRUE(spot.mesh.has_uvs());
  EXPECT_EQ(spot.textures.size(), 3u);
  EXPECT_FALSE(spot.material.diffuse_albedo.is_constant());
  EXPECT_FALSE(spot.material.roughness.is_constant());
  // Spatially varying roughness: glossy patches and a rougher base.
  const Image& roughness = spot.textures.at("spot_roughness");
  float lo = 1, hi = 0;
  for (float r : roughness.data()) {
    lo = std::min(lo, r);
    hi = std::max(hi, r);
  }
  EXPECT_LT(lo, 0.2f);
  EXPECT_GT(hi, 0.45f);
}

TEST(Scene, BoardTextureMatchesTheBoardFrame) {
  BoardSpec spec;
  cv::Mat image;
  const SynthObject board = MakeBoardObject(spec, 3000, 30, &image);
  // Corner 0 (one square in from the printed top-left) sits between a black
  // square (top-left) and white squares: sample the texture around it.
  const Eigen::Vector3d corner = CharucoCornersWorld(spec)[0];
  const Eigen::AlignedBox3f box = board.mesh.Bounds();
  auto albedo_at = [&](double x, double y) {
    const float u = static_cast<float>((x - box.min().x()) / box.sizes().x());
    const float v = static_cast<float>((y - box.min().y()) / box.sizes().y());
    return board.material.diffuse_albedo.Eval(render::Vec2f(u, v))[0];
  };
  const double d = 0.002;
  EXPECT_LT(albedo_at(corner.x() - d, corner.y() + d), 0.1);  // first square (top-left) is black
  EXPECT_LT(albedo_at(corner.x() + d, corner.y() - d), 0.1);
  EXPECT_GT(albedo_at(corner.x() + d, corner.y() + d), 0.7);
  EXPECT_GT(albedo_at(corner.x() - d, corner.y() - d), 0.7);
  // White paper margin outside the print.
  EXPECT_GT(albedo_at(-spec.width_m() / 2 - 0.005, 0), 0.7);
}

TEST(Scene, CustomMeshFromPly) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("relit_synth_mesh_" + std::to_string(::getpid()) + ".ply")).string();
  render::SaveMesh(path, render::MakeSphere(Eigen::Vector3f(1, 2, 3), 0.5f, 16, 8));
  const SynthScene scene = BuildScene("mesh", BoardSpec(), DefaultAssetsDir(), CustomMesh{path, 0.1, false});
  std::filesystem::remove(path);
  const Eigen::AlignedBox3f box = scene.objects.front().mesh.Bounds();
  EXPECT_NEAR(box.sizes().z(), 0.1, 1e-5);
  EXPECT_NEAR(box.min().z(), 0.0005, 1e-5);
  EXPECT_NEAR(box.center().x(), 0.0, 1e-5);
  EXPECT_THROW(BuildScene("mesh", BoardSpec(), DefaultAssetsDir(), CustomMesh{"/nonexistent.ply"}),
               std::runtime_error);
}

}  // namespace
}  // namespace relit::synth
