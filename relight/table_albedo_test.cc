// The table albedo measured against the paper (table_albedo.h) on frames
// whose radiance is known in closed form: a sphere on the board and table,
// a point flash of unknown strength, Lambert plane radiance plus noise.
#include "relight/table_albedo.h"

#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/image.h"
#include "core/render/mesh.h"
#include "relight/cue_frames.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;

class TableAlbedoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relit_table_albedo_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    plane_.enabled = true;
    plane_.board.dictionary = "DICT_4X4_50";
    plane_.table_albedo = Eigen::Vector3d::Constant(0.5);  // a placeholder: the estimate must not read it
    const fs::path mesh = dir_ / "sphere.obj";
    render::SaveMesh(mesh.string(), render::MakeSphere(Eigen::Vector3f(0, 0, 0.04f), 0.04f, 32, 16));
    scene_ = LoadProxyScene(mesh.string(), plane_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A frame seen from `eye` under a flash at `light` `scale` times the unit
  // strength: radiance = albedo x scale x cos / (pi r^2) on the plane where
  // the flash reaches it, 0.3 on the sphere, 0 in its shadow; Gaussian noise.
  TableAlbedoFrame RenderFrame(int index, const Eigen::Vector3d& eye, const Eigen::Vector3d& light,
                               const Eigen::Vector3d& table_albedo, double scale) {
    TableAlbedoFrame frame;
    frame.camera = Camera(Intrinsics::FromFov(160, 120, 1.1), LookAt(eye, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()));
    frame.light_position_m = light;
    std::mt19937 rng(index);
    std::normal_distribution<float> noise(0.0f, 0.004f);
    Image image(160, 120, 3);
    const render::Vec3f origin = eye.cast<float>();
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        const render::Vec3f direction = frame.camera.PixelToWorldRay({x + 0.5, y + 0.5}).cast<float>();
        render::Hit hit;
        if (!scene_->Intersect(origin, direction, 1e-4f, 1e4f, &hit)) continue;
        for (int c = 0; c < 3; ++c) image.at(x, y, c) = 0.3f + noise(rng);
        if (hit.object_id != kSupportBoardObjectId && hit.object_id != kSupportTableObjectId) continue;
        const render::Vec3f to_light = light.cast<float>() - hit.position;
        const float distance = to_light.norm();
        const bool lit = !scene_->Occluded(hit.position + 1e-4f * render::Vec3f::UnitZ(), to_light / distance, 0.0f,
                                           distance - 1e-3f);
        const double irradiance = lit ? scale * to_light.z() / distance / (M_PI * distance * distance) : 0.0;
        for (int c = 0; c < 3; ++c) {
          const double albedo = hit.object_id == kSupportTableObjectId
                                    ? table_albedo[c]
                                    : scene_->material(hit.material).At(hit.uv).diffuse[c];
          image.at(x, y, c) = static_cast<float>(albedo * irradiance) + noise(rng);
        }
      }
    }
    frame.image_path = (dir_ / (std::to_string(index) + ".exr")).string();
    WriteImage(frame.image_path, image);
    return frame;
  }

  fs::path dir_;
  SupportPlane plane_;
  std::unique_ptr<render::Scene> scene_;
};

TEST_F(TableAlbedoTest, MeasuresTheTableAgainstThePaperWhateverTheFlashStrength) {
  const Eigen::Vector3d truth(0.22, 0.14, 0.08);
  std::vector<TableAlbedoFrame> frames;
  for (int i = 0; i < 6; ++i) {
    const double azimuth = 0.9 * i;
    const Eigen::Vector3d eye(0.35 * std::cos(azimuth), 0.35 * std::sin(azimuth), 0.25);
    const Eigen::Vector3d light(0.3 * std::cos(azimuth + 0.6), 0.3 * std::sin(azimuth + 0.6), 0.3);
    frames.push_back(RenderFrame(i, eye, light, truth, 0.02 * (1 + 0.2 * i)));  // the exposure drifts
  }
  const TableAlbedoEstimate estimate = EstimateTableAlbedo(*scene_, plane_, frames);
  ASSERT_TRUE(estimate.found) << estimate.reason;
  EXPECT_EQ(estimate.frames_used, 6);
  EXPECT_GT(estimate.table_pixels, 1000);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(estimate.table_albedo[c], truth[c], 0.03 * truth[c]) << c;
}

TEST_F(TableAlbedoTest, SaysWhyWhenNoTableIsLit) {
  // The flash below the plane: nothing is lit directly.
  const Eigen::Vector3d eye(0.35, 0, 0.25);
  std::vector<TableAlbedoFrame> frames = {RenderFrame(0, eye, Eigen::Vector3d(0, 0, -0.2), Eigen::Vector3d::Constant(0.3), 0.02)};
  const TableAlbedoEstimate estimate = EstimateTableAlbedo(*scene_, plane_, frames);
  EXPECT_FALSE(estimate.found);
  EXPECT_NE(estimate.reason.find("lit table pixels"), std::string::npos) << estimate.reason;
}

}  // namespace
}  // namespace relit::relight
