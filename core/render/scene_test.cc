#include "core/render/scene.h"

#include <gtest/gtest.h>

#include "core/image.h"
#include "core/render/mesh.h"

namespace relit::render {
namespace {

// A unit quad in the z = 0 plane seen from above, with `material`, placed
// by `world_from_object`; returns the hit at the quad's centre.
Hit HitQuadCentre(const Material& material, const Eigen::Affine3f& world_from_object) {
  Scene scene;
  const int mesh = scene.AddMesh(MakeQuad(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitX(),
                                          Eigen::Vector3f::UnitY(), 0.5f, 0.5f));
  scene.AddInstance(mesh, scene.AddMaterial(material), world_from_object, 1);
  scene.Commit();
  const Vec3f origin = world_from_object * Vec3f(0.1f, 0.2f, 1.0f);
  const Vec3f direction = world_from_object.linear() * Vec3f(0, 0, -1);
  Hit hit;
  EXPECT_TRUE(scene.Intersect(origin, direction, 0, 10, &hit));
  return hit;
}

Image ConstantNormalMap(const Vec3f& normal) {
  Image map(4, 4, 3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      for (int c = 0; c < 3; ++c) map.at(x, y, c) = normal[c];
  return map;
}

TEST(SceneNormalMap, ShadingNormalComesFromTheMapInObjectSpace) {
  const Vec3f tilted = Vec3f(0.6f, 0.0f, 0.8f);
  Material material = Material::Lambert(Rgb::Constant(0.5f));
  // Without a map: the quad's own normal.
  Hit plain = HitQuadCentre(material, Eigen::Affine3f::Identity());
  EXPECT_NEAR(plain.shading_normal.z(), 1.0f, 1e-5f);
  material.normal_map = Texture::FromImage(ConstantNormalMap(tilted), false);
  const Hit mapped = HitQuadCentre(material, Eigen::Affine3f::Identity());
  EXPECT_LT((mapped.shading_normal - tilted).norm(), 1e-5f);
  EXPECT_NEAR(mapped.geometric_normal.z(), 1.0f, 1e-5f);  // the geometry does not move
  // A rotated instance rotates the mapped normal with it.
  const Eigen::Affine3f turn(Eigen::AngleAxisf(1.2f, Eigen::Vector3f(1, 2, 3).normalized()));
  const Hit turned = HitQuadCentre(material, turn);
  EXPECT_LT((turned.shading_normal - turn.linear() * tilted).norm(), 1e-5f);
}

TEST(SceneNormalMap, EmptyTexelsFallBackToTheVertexNormal) {
  Material material = Material::Lambert(Rgb::Constant(0.5f));
  material.normal_map = Texture::FromImage(ConstantNormalMap(Vec3f::Zero()), false);
  const Hit hit = HitQuadCentre(material, Eigen::Affine3f::Identity());
  EXPECT_NEAR(hit.shading_normal.z(), 1.0f, 1e-5f);
}

}  // namespace
}  // namespace relit::render
