// Cleanup and UV atlas on the synthetic spot cow: a "user mesh" made of the
// ground-truth cow with holes, a floater, the board and the table.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/render/mesh.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/uv_atlas.h"
#include "tools/synth/scene.h"

namespace relit::reconstruct {
namespace {

void Append(render::TriangleMesh* to, const render::TriangleMesh& from) {
  const int base = static_cast<int>(to->positions.size());
  to->positions.insert(to->positions.end(), from.positions.begin(), from.positions.end());
  for (const Eigen::Vector3i& t : from.triangles) to->triangles.push_back(t + Eigen::Vector3i::Constant(base));
}

struct Fixture {
  render::TriangleMesh truth;   // the cow
  render::TriangleMesh input;   // cow with holes + floater + board + table
  CropRegion crop;
};

const Fixture& GetFixture() {
  static const Fixture fixture = [] {
    Fixture f;
    const synth::SynthScene scene = synth::BuildScene("spot", BoardSpec{}, synth::DefaultAssetsDir());
    for (const synth::SynthObject& object : scene.objects) {
      render::TriangleMesh mesh;
      mesh.positions = object.mesh.positions;
      mesh.triangles = object.mesh.triangles;
      if (object.foreground) {
        Append(&f.truth, mesh);
        // Two holes: drop the faces near two surface points.
        render::TriangleMesh holed;
        holed.positions = mesh.positions;
        const Eigen::Vector3f a = mesh.positions[0], b = mesh.positions[mesh.positions.size() / 2];
        for (const Eigen::Vector3i& t : mesh.triangles) {
          const Eigen::Vector3f c = (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3;
          if ((c - a).norm() > 0.008f && (c - b).norm() > 0.006f) holed.triangles.push_back(t);
        }
        EXPECT_LT(holed.triangles.size(), mesh.triangles.size());
        Append(&f.input, holed);
      } else {
        Append(&f.input, mesh);  // board and table
      }
    }
    Append(&f.input, render::MakeSphere(scene.target_world.cast<float>() + Eigen::Vector3f(0.05f, 0.04f, 0.06f),
                                        0.004f, 12, 6));
    f.crop.centre_xy = scene.target_world.head<2>();
    f.crop.radius_m = 0.2;
    return f;
  }();
  return fixture;
}

const render::TriangleMesh& CleanedMesh() {
  static const render::TriangleMesh mesh = [] {
    CleanupReport report;
    return CleanupMesh(GetFixture().input, CleanupOptions{}, GetFixture().crop, &report);
  }();
  return mesh;
}

TEST(Cleanup, SpotWithBoardFloaterAndHolesBecomesOneClosedManifold) {
  CleanupOptions options;
  CleanupReport report;
  const render::TriangleMesh mesh = CleanupMesh(GetFixture().input, options, GetFixture().crop, &report);
  EXPECT_GE(report.components_in, 2);       // cow + floater
  EXPECT_EQ(report.components_kept, 1);
  EXPECT_GE(report.holes_filled, 2);        // the punched holes (+ the cropped hooves)
  const MeshStats stats = AnalyseMesh(mesh);
  std::cout << "cleanup: " << report.ToJson().dump() << "\nstats: " << stats.ToJson().dump() << "\n";
  EXPECT_TRUE(stats.closed());
  EXPECT_TRUE(stats.manifold());
  EXPECT_EQ(stats.components, 1);
  EXPECT_GT(stats.volume_m3, 0);            // outward orientation
  EXPECT_LE(stats.faces, options.target_faces);
  EXPECT_GE(stats.faces, options.target_faces * 8 / 10);
  // No board: nothing at or below the board plane.
  float min_z = 1e9f;
  for (const Eigen::Vector3f& p : mesh.positions) min_z = std::min(min_z, p.z());
  EXPECT_GT(min_z, 0.0f);
  const double diagonal = GetFixture().truth.Bounds().diagonal().norm();
  const double chamfer = SymmetricChamferDistance(mesh, GetFixture().truth, 20000);
  std::cout << "chamfer: " << chamfer * 1000 << " mm = " << 100 * chamfer / diagonal << "% of the diagonal\n";
  EXPECT_LT(chamfer / diagonal, 0.005);
}

TEST(Cleanup, ChamferDetectsADifferentShape) {
  const render::TriangleMesh& mesh = CleanedMesh();
  render::TriangleMesh shifted = mesh;
  for (Eigen::Vector3f& p : shifted.positions) p.x() += 0.01f;
  EXPECT_NEAR(SymmetricChamferDistance(mesh, mesh, 2000), 0.0, 1e-6);
  EXPECT_GT(SymmetricChamferDistance(shifted, mesh, 2000), 0.003);
}

TEST(Cleanup, BadInputsAreClearErrors) {
  CleanupReport report;
  CropRegion crop;
  EXPECT_THROW(CleanupMesh(render::TriangleMesh{}, CleanupOptions{}, crop, &report), Error);
  // Below the board plane only.
  const render::TriangleMesh below = render::MakeSphere({0, 0, -0.5f}, 0.1f, 16, 8);
  try {
    CleanupMesh(below, CleanupOptions{}, crop, &report);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("crops to nothing"), std::string::npos) << e.what();
  }
  // Three triangles on one edge: non-manifold.
  render::TriangleMesh fan;
  fan.positions = {{0, 0, 0.1f}, {0.1f, 0, 0.1f}, {0.05f, 0.05f, 0.15f}, {0.05f, -0.05f, 0.15f}, {0.05f, 0, 0.2f}};
  fan.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  CleanupOptions strict;
  strict.repair_non_manifold = false;
  try {
    CleanupMesh(fan, strict, crop, &report);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not manifold"), std::string::npos) << e.what();
  }
  EXPECT_GT(AnalyseMesh(fan).non_manifold_edges, 0);
}

TEST(Atlas, CleanedSpotAtlasHasNoOverlapsNoFlipsAndGoodUtilisation) {
  const render::TriangleMesh& mesh = CleanedMesh();
  AtlasOptions options;
  AtlasStats stats;
  const UvAtlas atlas = BuildAtlas(mesh, options, &stats);
  std::cout << "atlas: " << stats.ToJson().dump() << "\n";
  EXPECT_EQ(stats.overlapping_texels, 0);
  EXPECT_EQ(stats.flipped_triangles, 0);
  EXPECT_EQ(stats.chart_contact_texels, 0);
  EXPECT_GE(stats.min_chart_gap_texels, options.gutter_px);
  EXPECT_GE(stats.utilisation, 0.5);
  EXPECT_LT(stats.stretch_l2_mean, 1.5);
  for (const Eigen::Vector2f& uv : atlas.corner_uvs) {
    ASSERT_GE(uv.minCoeff(), 0.0f);
    ASSERT_LE(uv.maxCoeff(), 1.0f);
  }
  // The OBJ keeps shared positions (watertight) and per-corner UVs.
  const std::string dir = testing::TempDir() + "/reconstruct_atlas";
  std::filesystem::create_directories(dir);
  WriteObjWithAtlas(dir + "/proxy.obj", mesh, atlas);
  EXPECT_TRUE(std::filesystem::exists(dir + "/proxy.mtl"));
  const render::TriangleMesh loaded = render::LoadMesh(dir + "/proxy.obj");
  ASSERT_TRUE(loaded.has_uvs());
  ASSERT_EQ(loaded.triangles.size(), mesh.triangles.size());
  const MeshStats loaded_stats = AnalyseMesh(loaded);
  EXPECT_TRUE(loaded_stats.closed());
  EXPECT_TRUE(loaded_stats.manifold());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_LT((loaded.uvs[loaded.triangles[f][k]] - atlas.corner_uvs[3 * f + k]).norm(), 1e-5f);
    }
  }
}

TEST(Atlas, MeasureAtlasDetectsOverlapsAndFlips) {
  const render::TriangleMesh& mesh = CleanedMesh();
  AtlasStats stats;
  UvAtlas atlas = BuildAtlas(mesh, AtlasOptions{}, &stats);
  UvAtlas broken = atlas;
  // Move chart 1 onto chart 0 and mirror chart 2.
  Eigen::Vector2f shift = Eigen::Vector2f::Zero();
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (atlas.face_chart[f] == 0) shift = atlas.corner_uvs[3 * f];
  }
  Eigen::Vector2f chart1 = Eigen::Vector2f::Zero();
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (atlas.face_chart[f] == 1) chart1 = atlas.corner_uvs[3 * f];
  }
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector2f& uv = broken.corner_uvs[3 * f + k];
      if (atlas.face_chart[f] == 1) uv += shift - chart1;
      if (atlas.face_chart[f] == 2) uv.x() = 1.0f - uv.x();
    }
  }
  const AtlasStats bad = MeasureAtlas(mesh, broken);
  EXPECT_GT(bad.overlapping_texels, 0);
  EXPECT_GT(bad.flipped_triangles, 0);
  EXPECT_GT(bad.chart_contact_texels, 0);
}

}  // namespace
}  // namespace relit::reconstruct
