// The table albedo measured against the paper (support_albedo.h) on frames
// whose radiance is known in closed form: a sphere on the board and table,
// a point flash of unknown strength, Lambert plane radiance plus noise.
#include "relight/support_albedo.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/image.h"
#include "core/median.h"
#include "core/render/mesh.h"
#include "relight/cue_frames.h"

namespace relit::relight {
namespace {

namespace fs = std::filesystem;

class SupportAlbedoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("relit_support_albedo_" + std::to_string(::getpid()));
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
  // The coaster (kCoaster*) covers the print with its own albedo.
  SupportAlbedoFrame RenderFrame(int index, const Eigen::Vector3d& eye, const Eigen::Vector3d& light,
                                 const Eigen::Vector3d& table_albedo, double scale) {
    SupportAlbedoFrame frame;
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
          const double albedo = hit.object_id == kSupportTableObjectId ? table_albedo[c]
                                : OnCoaster(hit.position.x(), hit.position.y())
                                    ? kCoasterAlbedo[c]
                                    : scene_->material(hit.material).At(hit.uv).diffuse[c];
          image.at(x, y, c) = static_cast<float>(albedo * irradiance) + noise(rng);
        }
      }
    }
    frame.image_path = (dir_ / (std::to_string(index) + ".exr")).string();
    WriteImage(frame.image_path, image);
    return frame;
  }

  static bool OnCoaster(double x, double y, double margin = 0) {
    return x > kCoasterMin.x() - margin && x < kCoasterMax.x() + margin && y > kCoasterMin.y() - margin &&
           y < kCoasterMax.y() + margin;
  }
  std::vector<SupportAlbedoFrame> CircleOfFrames(const Eigen::Vector3d& table_albedo) {
    std::vector<SupportAlbedoFrame> frames;
    for (int i = 0; i < 6; ++i) {
      const double azimuth = 0.9 * i;
      const Eigen::Vector3d eye(0.35 * std::cos(azimuth), 0.35 * std::sin(azimuth), 0.25);
      const Eigen::Vector3d light(0.3 * std::cos(azimuth + 0.6), 0.3 * std::sin(azimuth + 0.6), 0.3);
      frames.push_back(RenderFrame(i, eye, light, table_albedo, 0.02 * (1 + 0.2 * i)));  // the exposure drifts
    }
    return frames;
  }

  static inline const Eigen::Vector2d kCoasterMin{0.05, -0.03}, kCoasterMax{0.11, 0.03};  // metres
  static inline const Eigen::Vector3d kCoasterAlbedo{0.45, 0.45, 0.42};
  fs::path dir_;
  SupportPlane plane_;
  std::unique_ptr<render::Scene> scene_;
};

TEST_F(SupportAlbedoTest, MeasuresTheTableAgainstThePaperWhateverTheFlashStrength) {
  const Eigen::Vector3d truth(0.22, 0.14, 0.08);
  const SupportAlbedoEstimate estimate = EstimateSupportAlbedo(*scene_, plane_, CircleOfFrames(truth));
  ASSERT_TRUE(estimate.found) << estimate.reason;
  EXPECT_EQ(estimate.frames_used, 6);
  EXPECT_GT(estimate.table_pixels, 1000);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(estimate.table_albedo[c], truth[c], 0.03 * truth[c]) << c;
  // The frames' flash scales are 0.02 x (1 + 0.2 i), i = 0..5: the median (upper middle) is i = 3's.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(estimate.flash_scale[c], 0.032, 0.002) << c;
}

TEST_F(SupportAlbedoTest, MapsWhatCoversThePrint) {
  SupportAlbedoOptions options;
  options.pixel_stride = 1;
  options.board_texel_m = 0.006;  // the frames' pixels are ~3 mm on the board
  const SupportAlbedoEstimate estimate =
      EstimateSupportAlbedo(*scene_, plane_, CircleOfFrames(Eigen::Vector3d::Constant(0.3)), options);
  const Image& map = estimate.board_albedo;
  ASSERT_FALSE(map.empty());
  EXPECT_GT(estimate.board_measured_fraction, 0.3);
  // Texel centres in world metres: the quad is centred on the origin, rows from its top (+Y).
  const BoardQuad quad = MakeBoardQuad(plane_);
  const Image print = MakeBoardQuad(plane_).print_albedo;
  std::vector<double> coaster[3], paper;  // their texels' values
  for (int ty = 0; ty < map.height(); ++ty) {
    for (int tx = 0; tx < map.width(); ++tx) {
      const double x = -quad.half_x_m + (tx + 0.5) * 2 * quad.half_x_m / map.width();
      const double y = quad.half_y_m - (ty + 0.5) * 2 * quad.half_y_m / map.height();
      if (OnCoaster(x, y, -0.006)) {
        for (int c = 0; c < 3; ++c) coaster[c].push_back(map.at(tx, ty, c));
        continue;
      }
      if (OnCoaster(x, y, 0.006)) continue;
      // Texels whose print is paper all over (the print's pixels under the texel, and a ring around it).
      const int px = static_cast<int>((tx + 0.5) * print.width() / map.width());
      const int py = static_cast<int>((ty + 0.5) * print.height() / map.height());
      const int reach = print.width() / map.width() + 2;
      bool all_paper = true;
      for (int dy = -reach; dy <= reach && all_paper; ++dy) {
        for (int dx = -reach; dx <= reach && all_paper; ++dx) {
          const int qx = std::clamp(px + dx, 0, print.width() - 1), qy = std::clamp(py + dy, 0, print.height() - 1);
          all_paper = print.at(qx, qy, 0) > 0.79f;
        }
      }
      if (all_paper) paper.push_back(map.at(tx, ty, 1));
    }
  }
  ASSERT_GT(coaster[0].size(), 20u);
  ASSERT_GT(paper.size(), 100u);
  // Each texel on the right side of halfway between the coaster (0.45) and
  // the paper (0.8) or the ink (0.03): the frames' noise is ~15 % of the
  // coaster's radiance, a texel has a few samples.
  auto share = [](const std::vector<double>& v, double low, double high) {
    return std::count_if(v.begin(), v.end(), [&](double a) { return a > low && a < high; }) / double(v.size());
  };
  EXPECT_GT(share(coaster[1], 0.24, 0.62), 0.95);
  EXPECT_GT(share(paper, 0.62, 1.0), 0.95);
  // The medians to a few per cent.
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(Median(coaster[c]), kCoasterAlbedo[c], 0.05 * kCoasterAlbedo[c]) << c;
  EXPECT_NEAR(Median(paper), plane_.paper_albedo, 0.04 * plane_.paper_albedo);
}

TEST_F(SupportAlbedoTest, SaysWhyWhenNoTableIsLit) {
  // The flash below the plane: nothing is lit directly.
  const Eigen::Vector3d eye(0.35, 0, 0.25);
  std::vector<SupportAlbedoFrame> frames = {RenderFrame(0, eye, Eigen::Vector3d(0, 0, -0.2), Eigen::Vector3d::Constant(0.3), 0.02)};
  const SupportAlbedoEstimate estimate = EstimateSupportAlbedo(*scene_, plane_, frames);
  EXPECT_FALSE(estimate.found);
  EXPECT_NE(estimate.reason.find("lit table pixels"), std::string::npos) << estimate.reason;
}

}  // namespace
}  // namespace relit::relight
