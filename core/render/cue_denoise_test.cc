#include "core/render/cue_denoise.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/render/cue_renderer.h"
#include "core/render/envmaps.h"

namespace relit::render {
namespace {

// A sphere standing on a plane, seen from above at an angle, under the sky
// map (a sun and a sky): sharp GGX cues are noisy at few paths per pixel.
struct SkyScene {
  Scene scene;
  Camera camera;
  SkyScene()
      : camera(Intrinsics::FromFov(48, 48, 40.0 * M_PI / 180.0),
               LookAt(Eigen::Vector3d(0.5, -0.7, 0.6), Eigen::Vector3d(0, 0, 0.1), Eigen::Vector3d::UnitZ())) {
    scene.AddObject(MakeSphere(Vec3f(0, 0, 0.12f), 0.12f, 48, 24), Material::Lambert(Rgb::Ones()), 1);
    scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.8f, 0.8f),
                    Material::Lambert(Rgb::Constant(0.5f)), 2);
    scene.SetEnvironment(EnvironmentLight(MakeSkyMap(128, 0.6, 1.0)));
    scene.Commit();
  }
  RenderResult Render(int spp, uint64_t seed) const {
    RenderOptions options;
    options.samples_per_pixel = spp;
    options.max_depth = 3;
    options.seed = seed;
    options.environment_visible = false;
    options.alpha_object_ids = {1};
    return RenderCues(scene, camera, options);
  }
};

// Mean squared difference of one RGB triple (basis k) over the pixels whose
// centre ray hits the sphere.
double SphereMse(const RenderResult& aovs, const Image& a, const Image& b, int k) {
  double sum = 0;
  long count = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      if (aovs.object_id.at(x, y, 0) != 1) continue;
      for (int c = 3 * k; c < 3 * k + 3; ++c) sum += std::pow(a.at(x, y, c) - b.at(x, y, c), 2);
      ++count;
    }
  }
  return sum / std::max<long>(1, 3 * count);
}

TEST(CueDenoise, CutsEnvironmentNoiseWithoutSmearingGlints) {
  const SkyScene sky;
  const RenderResult noisy = sky.Render(16, 3);
  const RenderResult reference = sky.Render(1024, 7);
  const std::vector<CueBasis> basis = DefaultCueBasis();
  const Image filtered = DenoiseCues(noisy, noisy.radiance, {}, CueNormalSigmas(basis));
  std::vector<double> ratio;
  for (size_t k = 0; k < basis.size(); ++k) {
    ratio.push_back(SphereMse(noisy, filtered, reference.radiance, k) /
                    SphereMse(noisy, noisy.radiance, reference.radiance, k));
  }
  // Measured: Lambert's error falls to 0.26x, GGX 0.34's to 0.55x. The sun's
  // glint in the sharp cues is real: one normal sigma for every basis
  // smeared it and tripled their error; they must stay as they were.
  EXPECT_LT(ratio[0], 0.4);
  EXPECT_LT(ratio[4], 0.75);
  for (size_t k = 1; k <= 3; ++k) EXPECT_LT(ratio[k], 1.02) << "basis " << k;
  // The filter averages, it does not brighten or darken: the sphere's mean
  // Lambert cue is kept to within 2 %.
  double mean_in = 0, mean_out = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 48; ++x) {
      if (noisy.object_id.at(x, y, 0) != 1) continue;
      mean_in += reference.radiance.at(x, y, 0);
      mean_out += filtered.at(x, y, 0);
    }
  }
  EXPECT_NEAR(mean_out / mean_in, 1.0, 0.03);
}

TEST(CueDenoise, KeepsCoverageAndLeavesMissedPixelsAlone) {
  // One surface of radiance 0.8 (flat, facing the camera); its right column
  // is a silhouette covered a quarter, its left column missed by the centre
  // rays (whatever a stray sample left there stays).
  RenderResult aovs;
  aovs.alpha = Image(9, 5, 1, 1.0f);
  aovs.normal = Image(9, 5, 3);
  aovs.depth = Image(9, 5, 1, 1.0f);
  aovs.object_id = Image(9, 5, 1, 1.0f);
  Image radiance(9, 5, 3, 0.8f);
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 9; ++x) aovs.normal.at(x, y, 2) = 1;
    aovs.alpha.at(8, y, 0) = 0.25f;
    for (int c = 0; c < 3; ++c) radiance.at(8, y, c) = 0.25f * 0.8f;
    aovs.object_id.at(0, y, 0) = -1;
    aovs.alpha.at(0, y, 0) = 0.1f;
    aovs.depth.at(0, y, 0) = 0;
    for (int c = 0; c < 3; ++c) radiance.at(0, y, c) = 0.05f;
  }
  const Image filtered = DenoiseCues(aovs, radiance);
  for (int y = 0; y < 5; ++y) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(filtered.at(0, y, c), 0.05f);
      EXPECT_NEAR(filtered.at(4, y, c), 0.8f, 1e-5);
      EXPECT_NEAR(filtered.at(8, y, c), 0.2f, 1e-5) << "the silhouette pixel keeps its coverage";
    }
  }
}

TEST(CueDenoise, DoesNotBlendAcrossObjectsOrDepth) {
  // Two halves of the image: pixels of object 1 bright, object 2 dark, the
  // same normal and depth. Nothing of one may reach the other.
  RenderResult aovs;
  aovs.alpha = Image(8, 4, 1, 1.0f);
  aovs.normal = Image(8, 4, 3);
  aovs.depth = Image(8, 4, 1, 1.0f);
  aovs.object_id = Image(8, 4, 1);
  Image radiance(8, 4, 1);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) {
      aovs.normal.at(x, y, 2) = 1;
      aovs.object_id.at(x, y, 0) = x < 4 ? 1 : 2;
      radiance.at(x, y, 0) = x < 4 ? 1.0f : 0.0f;
    }
  }
  Image filtered = DenoiseCues(aovs, radiance);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) EXPECT_FLOAT_EQ(filtered.at(x, y, 0), x < 4 ? 1.0f : 0.0f);
  }
  // One object, but the right half 20 % farther: a depth edge.
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) {
      aovs.object_id.at(x, y, 0) = 1;
      aovs.depth.at(x, y, 0) = x < 4 ? 1.0f : 1.2f;
    }
  }
  filtered = DenoiseCues(aovs, radiance);
  EXPECT_GT(filtered.at(3, 1, 0), 0.999f);
  EXPECT_LT(filtered.at(4, 1, 0), 0.001f);
}

}  // namespace
}  // namespace relit::render
