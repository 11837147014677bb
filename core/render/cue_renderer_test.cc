#include "core/render/cue_renderer.h"

#include <cmath>
#include <cstdio>
#include <functional>

#include <gtest/gtest.h>

namespace relit::render {
namespace {

Camera LookingAt(const Eigen::Vector3d& eye, int size, const Eigen::Vector3d& up = Eigen::Vector3d::UnitZ()) {
  return Camera(Intrinsics::FromFov(size, size, 45.0 * M_PI / 180.0), LookAt(eye, Eigen::Vector3d::Zero(), up));
}

TEST(CueRenderer, DefaultBasisIsLambertPlusFourGgx) {
  const auto basis = DefaultCueBasis();
  ASSERT_EQ(basis.size(), 5u);
  EXPECT_EQ(basis[0].bsdf.diffuse[0], 1.0f);
  EXPECT_EQ(basis[0].bsdf.specular[0], 0.0f);
  const float alphas[] = {0.02f, 0.05f, 0.13f, 0.34f};
  for (int k = 1; k < 5; ++k) {
    EXPECT_EQ(basis[k].bsdf.alpha, alphas[k - 1]);
    EXPECT_EQ(basis[k].bsdf.diffuse[0], 0.0f);
  }
  EXPECT_EQ(CueChannelNames(5).size(), 15u);
  EXPECT_EQ(CueChannelNames(5)[14], "cue4.B");
}

TEST(CueRenderer, LambertCueOfPlaneUnderColouredPointLightIsAnalytic) {
  const Vec3f light(0.05f, 0.1f, 0.6f);
  const Rgb intensity(0.5f, 1.0f, 2.0f);
  Scene scene;
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1, 1), Material::Lambert(Rgb::Constant(0.3f)), 1);
  scene.AddLight(PointLight{light, intensity});
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 64;
  const Camera camera = LookingAt({0, 0, 1.2}, 24, Eigen::Vector3d::UnitY());
  const RenderResult r = RenderCues(scene, camera, options);
  ASSERT_EQ(r.radiance.channels(), 15);
  // Reference: Lambert (albedo 1) radiance I cos / (pi d^2) averaged over the
  // pixel footprint on the plane z = 0.
  auto analytic = [&](double px, double py, int c) {
    const Eigen::Vector3d ray = camera.PixelToWorldRay({px, py});
    const Eigen::Vector3d o = camera.Center();
    const Vec3f d = light - (o - (o.z() / ray.z()) * ray).cast<float>();
    return intensity[c] * (d.z() / d.norm()) / (kPi * d.squaredNorm());
  };
  for (int y = 2; y < 22; y += 5) {
    for (int x = 2; x < 22; x += 5) {
      for (int c = 0; c < 3; ++c) {
        double expected = 0;
        for (int i = 0; i < 16; ++i) {
          for (int j = 0; j < 16; ++j) expected += analytic(x - 0.5 + (i + 0.5) / 16, y - 0.5 + (j + 0.5) / 16, c);
        }
        expected /= 256;
        EXPECT_NEAR(r.radiance.at(x, y, c), expected, 0.003 * expected);
      }
    }
  }
}

// Each cue must equal a plain path-traced render of the scene made of that
// basis material, including interreflections: the cues of a sphere on a
// plane lit by `light` against, per basis, the path tracer's image of the
// same scene in that material (image means: per-pixel noise is large for
// sharp lobes).
void ExpectEachCueMatchesPathTracer(const std::function<void(Scene*)>& light) {
  auto build = [&](const Material* material, Scene* scene) {
    const Material m = material ? *material : Material::Lambert(Rgb::Ones());
    scene->AddObject(MakeSphere(Vec3f(0, 0, 0.2f), 0.2f, 48, 24), m, 1);
    scene->AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.6f, 0.6f), m, 2);
    light(scene);
    scene->Commit();
  };
  Scene cue_scene;
  build(nullptr, &cue_scene);
  RenderOptions options;
  options.samples_per_pixel = 64;
  options.max_depth = 4;
  const Camera camera = LookingAt({0.6, -0.9, 0.7}, 20);
  const RenderResult cues = RenderCues(cue_scene, camera, options);
  const auto basis = DefaultCueBasis();
  for (size_t k = 0; k < basis.size(); ++k) {
    Material m;
    m.diffuse_albedo = basis[k].bsdf.diffuse;
    m.specular_albedo = basis[k].bsdf.specular;
    m.roughness = Rgb::Constant(basis[k].bsdf.alpha);
    m.f0 = basis[k].bsdf.f0;
    Scene scene;
    build(&m, &scene);
    RenderOptions reference_options = options;
    reference_options.seed = 99;
    const RenderResult reference = RenderImage(scene, camera, reference_options);
    double cue_sum = 0, ref_sum = 0, var_cue = 0, var_ref = 0;
    const int n = 20 * 20;
    for (int y = 0; y < 20; ++y) {
      for (int x = 0; x < 20; ++x) {
        const double a = cues.radiance.at(x, y, 3 * k), b = reference.radiance.at(x, y, 0);
        cue_sum += a;
        ref_sum += b;
        var_cue += a * a;
        var_ref += b * b;
      }
    }
    const double mean_cue = cue_sum / n, mean_ref = ref_sum / n;
    const double se = std::sqrt((var_cue / n - mean_cue * mean_cue + var_ref / n - mean_ref * mean_ref) / n);
    std::printf("%s: cue mean %.4f, path tracer %.4f (se %.4f)\n", basis[k].name.c_str(), mean_cue, mean_ref, se);
    EXPECT_NEAR(mean_cue, mean_ref, 4 * se + 0.01 * mean_ref) << basis[k].name;
  }
}

TEST(CueRenderer, EachCueMatchesPathTracerWithThatMaterial) {
  ExpectEachCueMatchesPathTracer(
      [](Scene* scene) { scene->AddLight(PointLight{Vec3f(0.3f, -0.4f, 0.8f), Rgb::Constant(1.0f)}); });
}

// The same under an environment map with a bright window (a sharp lobe
// finds it by BSDF sampling, a rough one by light sampling).
TEST(CueRenderer, EachCueMatchesPathTracerUnderAnEnvironmentMap) {
  ExpectEachCueMatchesPathTracer([](Scene* scene) {
    Image map(64, 32, 3, 0.2f);
    for (int y = 4; y < 10; ++y) {
      for (int x = 8; x < 16; ++x) {
        for (int c = 0; c < 3; ++c) map.at(x, y, c) = 20.0f;
      }
    }
    scene->SetEnvironment(EnvironmentLight(map));
  });
}

TEST(CueRenderer, SharesAovsWithPathTracer) {
  Scene scene;
  scene.AddObject(MakeSphere(Vec3f::Zero(), 0.3f), Material::Lambert(Rgb::Ones()), 4);
  scene.AddLight(DirectionalLight{Vec3f::UnitZ(), Rgb::Ones()});
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 4;
  const Camera camera = LookingAt({0, -1, 0.2}, 16);
  const RenderResult a = RenderCues(scene, camera, options), b = RenderImage(scene, camera, options);
  EXPECT_EQ(a.alpha.data(), b.alpha.data());
  EXPECT_EQ(a.uv.data(), b.uv.data());
  EXPECT_EQ(a.uv_derivatives.data(), b.uv_derivatives.data());
}

// Context objects (outside alpha_object_ids) keep their own material in every
// cue: the sphere's cues must equal a path-traced render of the sphere in
// that basis material standing on the plane with the plane's own material;
// a camera ray that sees the plane first adds nothing.
TEST(CueRenderer, ContextObjectKeepsItsMaterialAndIsBackground) {
  const Material plane_material = Material::Lambert(Rgb(0.7f, 0.5f, 0.3f));
  auto build = [&](const Material& sphere_material, bool with_plane, Scene* scene) {
    scene->AddObject(MakeSphere(Vec3f(0, 0, 0.2f), 0.2f, 48, 24), sphere_material, 1);
    if (with_plane) {
      scene->AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 0.6f, 0.6f), plane_material, 2);
    }
    scene->AddLight(PointLight{Vec3f(0.3f, -0.4f, 0.8f), Rgb::Constant(1.0f)});
    scene->Commit();
  };
  RenderOptions options;
  options.samples_per_pixel = 64;
  options.max_depth = 4;
  options.alpha_object_ids = {1};
  const Camera camera = LookingAt({0.6, -0.9, 0.25}, 20);
  Scene cue_scene, bare_scene;
  build(Material::Lambert(Rgb::Ones()), true, &cue_scene);
  build(Material::Lambert(Rgb::Ones()), false, &bare_scene);
  const RenderResult cues = RenderCues(cue_scene, camera, options);
  const RenderResult bare = RenderCues(bare_scene, camera, options);
  Scene reference_scene;
  build(Material::Lambert(Rgb::Ones()), true, &reference_scene);
  RenderOptions reference_options = options;
  reference_options.seed = 99;
  const RenderResult reference = RenderImage(reference_scene, camera, reference_options);
  double cue_sum = 0, ref_sum = 0, bare_sum = 0;
  int sphere_pixels = 0, plane_pixels = 0;
  for (int y = 0; y < 20; ++y) {
    for (int x = 0; x < 20; ++x) {
      if (cues.alpha.at(x, y, 0) == 1.0f) {
        ++sphere_pixels;
        for (int c = 0; c < 3; ++c) {
          cue_sum += cues.radiance.at(x, y, c);
          ref_sum += reference.radiance.at(x, y, c);
          bare_sum += bare.radiance.at(x, y, c);
        }
      } else if (cues.alpha.at(x, y, 0) == 0.0f && cues.object_id.at(x, y, 0) == 2) {
        ++plane_pixels;
        for (int k = 0; k < 15; ++k) EXPECT_EQ(cues.radiance.at(x, y, k), 0.0f) << x << "," << y;
      }
    }
  }
  ASSERT_GT(sphere_pixels, 50);
  ASSERT_GT(plane_pixels, 20);
  EXPECT_NEAR(cue_sum, ref_sum, 0.02 * ref_sum);
  // The plane's bounce is a visible share of the sphere's light from this low view.
  EXPECT_GT(cue_sum, 1.05 * bare_sum);
}

// A proxy with fitted cue weights wears their mixture past the primary hit,
// so the weighted sum of its cues is the image of the object made of those
// materials, inter-reflections included: a copper-like glossy sphere
// (ggx_0.13 weight c) on a red Lambert plane (weight a), both proxy, against
// the path tracer's image of that scene. With the basis itself past the
// primary hit the sphere would mirror a white plane: the same sum is then
// too bright in green and blue.
TEST(CueRenderer, FittedCueWeightsGiveTheirMaterialsInterReflections) {
  const Rgb c(0.9f, 0.6f, 0.5f), a(0.8f, 0.1f, 0.1f);
  const int kGlossy = 3;  // ggx_0.13
  auto weights = [](int basis, const Rgb& value) {
    std::vector<Texture> w(5, Texture(Rgb::Zero()));
    w[basis] = value;
    return w;
  };
  auto build = [&](bool fitted, bool reference, Scene* scene) {
    Material sphere, plane;
    if (reference) {
      sphere = Material::Glossy(Rgb::Zero(), c, 0.13f);
      sphere.f0 = Rgb::Ones();
      plane = Material::Lambert(a);
    } else if (fitted) {
      sphere.cue_weights = weights(kGlossy, c);
      plane.cue_weights = weights(0, a);
    }
    scene->AddObject(MakeSphere(Vec3f(0, 0, 0.2f), 0.2f, 48, 24), sphere, 1);
    scene->AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1.2f, 1.2f), plane, 1);
    scene->AddLight(PointLight{Vec3f(0.3f, -0.4f, 0.8f), Rgb::Constant(1.0f)});
    scene->Commit();
  };
  RenderOptions options;
  options.samples_per_pixel = 64;
  options.max_depth = 4;
  const Camera camera = LookingAt({0.5, -0.8, 0.35}, 24);
  Scene fitted_scene, basis_scene, reference_scene;
  build(true, false, &fitted_scene);
  build(false, false, &basis_scene);
  build(false, true, &reference_scene);
  const RenderResult fitted = RenderCues(fitted_scene, camera, options);
  const RenderResult basis = RenderCues(basis_scene, camera, options);
  RenderOptions reference_options = options;
  reference_options.seed = 99;
  const RenderResult reference = RenderImage(reference_scene, camera, reference_options);
  // Per channel, over sphere pixels (which see the plane) and plane pixels.
  Rgb fitted_sphere = Rgb::Zero(), basis_sphere = Rgb::Zero(), ref_sphere = Rgb::Zero();
  Rgb fitted_plane = Rgb::Zero(), ref_plane = Rgb::Zero();
  int sphere_pixels = 0, plane_pixels = 0;
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      if (reference.alpha.at(x, y, 0) != 1.0f) continue;
      const bool on_sphere = reference.position.at(x, y, 2) > 0.005f;
      for (int ch = 0; ch < 3; ++ch) {
        const float ref = reference.radiance.at(x, y, ch);
        if (on_sphere) {
          fitted_sphere[ch] += c[ch] * fitted.radiance.at(x, y, 3 * kGlossy + ch);
          basis_sphere[ch] += c[ch] * basis.radiance.at(x, y, 3 * kGlossy + ch);
          ref_sphere[ch] += ref;
        } else {
          fitted_plane[ch] += a[ch] * fitted.radiance.at(x, y, ch);
          ref_plane[ch] += ref;
        }
      }
      ++(on_sphere ? sphere_pixels : plane_pixels);
    }
  }
  ASSERT_GT(sphere_pixels, 60);
  ASSERT_GT(plane_pixels, 60);
  for (int ch = 0; ch < 3; ++ch) {
    std::printf("channel %d: sphere fitted %.3f basis %.3f reference %.3f; plane fitted %.3f reference %.3f\n", ch,
                fitted_sphere[ch], basis_sphere[ch], ref_sphere[ch], fitted_plane[ch], ref_plane[ch]);
    EXPECT_NEAR(fitted_sphere[ch], ref_sphere[ch], 0.04 * ref_sphere[ch]) << ch;
    EXPECT_NEAR(fitted_plane[ch], ref_plane[ch], 0.03 * ref_plane[ch]) << ch;
  }
  // The basis past the primary hit mirrors a white plane: blue far too bright.
  EXPECT_GT(basis_sphere[2], 1.3 * ref_sphere[2]);
}

// The delta light's direct light kept apart: the two halves sum to the
// plain cues, the apart half is the part without path-tracing noise (the
// same in two renders with different seeds, up to the pixel footprint),
// and a map has no such part.
TEST(CueRenderer, DeltaDirectApartSumsToTheCuesAndHoldsNoBounceNoise) {
  Scene scene;
  scene.AddObject(MakeSphere(Vec3f(0, 0, 0.2f), 0.2f, 48, 24), Material::Lambert(Rgb::Ones()), 1);
  scene.AddObject(MakeQuad(Vec3f::Zero(), Vec3f::UnitX(), Vec3f::UnitY(), 1.2f, 1.2f),
                  Material::Lambert(Rgb::Constant(0.5f)), 2);
  scene.AddLight(PointLight{Vec3f(0.3f, -0.4f, 0.8f), Rgb::Constant(1.0f)});
  scene.Commit();
  RenderOptions options;
  options.samples_per_pixel = 16;
  options.max_depth = 3;
  options.alpha_object_ids = {1};
  const Camera camera = LookingAt({0.6, -0.9, 0.7}, 24);
  const RenderResult plain = RenderCues(scene, camera, options);
  const RenderResult split = RenderCuesDeltaDirectApart(scene, camera, options);
  ASSERT_EQ(split.radiance.channels(), 30);
  EXPECT_EQ(split.radiance.channel_names()[15], "direct.cue0.R");
  options.seed = 99;
  const RenderResult other_seed = RenderCuesDeltaDirectApart(scene, camera, options);
  double rest_change = 0, direct_change = 0, direct_sum = 0, rest_sum = 0;
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      for (int c = 0; c < 15; ++c) {
        const float rest = split.radiance.at(x, y, c), direct = split.radiance.at(x, y, 15 + c);
        EXPECT_NEAR(rest + direct, plain.radiance.at(x, y, c), 1e-5f + 1e-5f * plain.radiance.at(x, y, c));
        // The Lambert cue (a glossy lobe's highlight of a point light is a
        // few pixels wide: there the footprint's jitter is the noise).
        if (c >= 3 || split.object_id.at(x, y, 0) != 1 || split.alpha.at(x, y, 0) < 1) continue;
        rest_sum += rest;
        direct_sum += direct;
        rest_change += std::abs(rest - other_seed.radiance.at(x, y, c));
        direct_change += std::abs(direct - other_seed.radiance.at(x, y, 15 + c));
      }
    }
  }
  ASSERT_GT(rest_sum, 0) << "the sphere gets bounce light from the plane";
  ASSERT_GT(direct_sum, 0);
  // Relative to its own level, the Lambert cue's bounce light changes with
  // the seed far more than its direct light (only the footprint's jitter).
  EXPECT_GT(rest_change / rest_sum, 20 * direct_change / direct_sum);  // measured: 0.86 against 0.007

  scene.ClearLights();
  scene.SetEnvironment(EnvironmentLight(Image(16, 8, 3, 1.0f)));
  const RenderResult map = RenderCuesDeltaDirectApart(scene, camera, options);
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      for (int c = 15; c < 30; ++c) EXPECT_EQ(map.radiance.at(x, y, c), 0.0f);
    }
  }
}

}  // namespace
}  // namespace relit::render
