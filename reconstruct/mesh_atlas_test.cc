// Cleanup and UV atlas on the synthetic spot cow: a "user mesh" made of the
// ground-truth cow with holes, a floater, the board and the table.
#include <filesystem>
#include <random>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"
#include "core/render/mesh.h"
#include "reconstruct/mesh_cleanup.h"
#include "reconstruct/point_surface.h"
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


// Closed index mesh: genus from the Euler characteristic.
int Genus(const render::TriangleMesh& mesh) {
  std::set<std::pair<int, int>> edges;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) edges.insert({std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])});
  }
  const long chi = static_cast<long>(mesh.positions.size()) - static_cast<long>(edges.size()) +
                   static_cast<long>(mesh.triangles.size());
  return static_cast<int>((2 - chi) / 2);
}

// What screened Poisson makes of noisy fused depth: the cleaned cow with every
// vertex moved along its normal by Gaussian noise (sigma = `noise` x the mean
// edge length: bumps and folds) and `handles` tiny tunnels, each joining two
// nearby triangles (removed) by a three-sided tube under the surface.
render::TriangleMesh NoisyWithHandles(const render::TriangleMesh& clean, double noise, int handles) {
  render::TriangleMesh mesh = clean;
  const int n = static_cast<int>(mesh.positions.size());
  std::vector<Eigen::Vector3f> normals(n, Eigen::Vector3f::Zero());
  std::vector<std::set<int>> ring(n);
  double edge_sum = 0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3f face = (mesh.positions[t[1]] - mesh.positions[t[0]]).cross(mesh.positions[t[2]] - mesh.positions[t[0]]);
    for (int k = 0; k < 3; ++k) {
      normals[t[k]] += face;
      ring[t[k]].insert(t[(k + 1) % 3]);
      ring[t[k]].insert(t[(k + 2) % 3]);
      edge_sum += (mesh.positions[t[k]] - mesh.positions[t[(k + 1) % 3]]).norm();
    }
  }
  const double edge = edge_sum / (3.0 * mesh.triangles.size());
  std::mt19937 rng(7);
  std::normal_distribution<float> gauss(0.0f, static_cast<float>(noise * edge));
  for (int v = 0; v < n; ++v) mesh.positions[v] += gauss(rng) * normals[v].normalized();
  // Tunnels between faces whose vertices are 2-3 rings apart, away from other tunnels.
  std::vector<std::vector<int>> vertex_faces(n);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    for (int k = 0; k < 3; ++k) vertex_faces[mesh.triangles[f][k]].push_back(static_cast<int>(f));
  }
  std::vector<bool> used(n, false), dropped(mesh.triangles.size(), false);
  std::vector<Eigen::Vector3i> tubes;
  std::uniform_int_distribution<int> pick(0, static_cast<int>(mesh.triangles.size()) - 1);
  auto near = [&](int v, int depth) {
    std::set<int> out{v};
    for (int d = 0; d < depth; ++d) {
      std::set<int> next = out;
      for (int x : out) next.insert(ring[x].begin(), ring[x].end());
      out.swap(next);
    }
    return out;
  };
  for (int tries = 0; static_cast<int>(tubes.size()) < 6 * handles && tries < 100 * handles; ++tries) {
    const int f1 = pick(rng);
    const Eigen::Vector3i a = mesh.triangles[f1];
    const std::set<int> close = near(a[0], 1), far = near(a[0], 3);
    int f2 = -1;
    for (int v : far) {
      if (close.count(v)) continue;
      for (int g : vertex_faces[v]) {
        const Eigen::Vector3i& b = mesh.triangles[g];
        bool ok = true;
        for (int k = 0; k < 3; ++k) ok = ok && !near(b[k], 1).count(a[0]) && !near(b[k], 1).count(a[1]) && !near(b[k], 1).count(a[2]);
        if (ok) f2 = g;
      }
      if (f2 >= 0) break;
    }
    if (f2 < 0) continue;
    const Eigen::Vector3i b = mesh.triangles[f2];
    bool free = true;
    for (int k = 0; k < 3; ++k) {
      for (int x : near(a[k], 1)) free = free && !used[x];
      for (int x : near(b[k], 1)) free = free && !used[x];
    }
    if (!free) continue;
    for (int k = 0; k < 3; ++k) used[a[k]] = used[b[k]] = true;
    dropped[f1] = dropped[f2] = true;
    // The tube uses a's edges as f1 did and b's edges as f2 did: a0 -> b1, a1 -> b0, a2 -> b2.
    const int q[3] = {b[1], b[0], b[2]};
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3;
      tubes.push_back({a[k], a[k1], q[k1]});
      tubes.push_back({a[k], q[k1], q[k]});
    }
  }
  std::vector<Eigen::Vector3i> triangles;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!dropped[f]) triangles.push_back(mesh.triangles[f]);
  }
  triangles.insert(triangles.end(), tubes.begin(), tubes.end());
  mesh.triangles = std::move(triangles);
  return mesh;
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

TEST(Points, OrientedPlyRoundTripsAndShortFilesAreErrors) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("relit_ply_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::vector<OrientedPoint> points;
  for (int i = 0; i < 5; ++i) {
    points.push_back({Eigen::Vector3d(0.01 * i, -0.02 * i, 0.5), Eigen::Vector3d(0, 0.6, 0.8)});
  }
  const std::string path = (dir / "points.ply").string();
  WriteOrientedPly(path, points);
  const std::vector<OrientedPoint> back = ReadOrientedPly(path);
  ASSERT_EQ(back.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_LT((back[i].position_m - points[i].position_m).norm(), 1e-7);
    EXPECT_LT((back[i].normal - points[i].normal).norm(), 1e-7);
  }
  std::filesystem::resize_file(path, std::filesystem::file_size(path) - 10);
  EXPECT_THROW(ReadOrientedPly(path), Error);
  EXPECT_THROW(ReadOrientedPly((dir / "missing.ply").string()), Error);
  std::filesystem::remove_all(dir);
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

// The atlas requirements: no texel covered twice, no flipped or
// degenerate UV triangle, charts apart by the gutter, >= 50 % utilisation.
void ExpectValidAtlas(const AtlasStats& stats, const AtlasOptions& options) {
  EXPECT_EQ(stats.overlapping_texels, 0);
  EXPECT_EQ(stats.flipped_triangles, 0);
  EXPECT_EQ(stats.degenerate_triangles, 0);
  EXPECT_EQ(stats.chart_contact_texels, 0);
  EXPECT_GE(stats.min_chart_gap_texels, options.gutter_px);
  EXPECT_GE(stats.utilisation, 0.5);
  EXPECT_LT(stats.stretch_l2_mean, 1.5);
}

TEST(Atlas, CleanedSpotAtlasHasNoOverlapsNoFlipsAndGoodUtilisation) {
  const render::TriangleMesh& mesh = CleanedMesh();
  AtlasOptions options;
  AtlasStats stats;
  const UvAtlas atlas = BuildAtlas(mesh, options, &stats);
  std::cout << "atlas: " << stats.ToJson().dump() << "\n";
  ExpectValidAtlas(stats, options);
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

// The calibrated proxies are noisy and full of tiny handles; chart growing
// and splitting alone fragments them into > 1000 charts (20-30% of the
// atlas; on this mesh 1373 charts, 20%, measured with atlas.merge_charts
// false, whose packing alone takes 20 s).
TEST(Atlas, NoisyProxyWithTinyHandlesFillsHalfTheAtlas) {
  const render::TriangleMesh& clean = CleanedMesh();
  ASSERT_EQ(Genus(clean), 0);
  const render::TriangleMesh noisy = NoisyWithHandles(clean, 0.25, 120);
  const int genus = Genus(noisy);
  EXPECT_GE(genus, 80);
  AtlasOptions options;
  AtlasStats before;
  BuildAtlas(noisy, options, &before);
  std::cout << "noisy, genus " << genus << ", charts merged: " << before.ToJson().dump() << "\n";

  render::TriangleMesh cut = noisy;
  const int cuts = CutSmallHandles(&cut, 0.01);
  const MeshStats topology = AnalyseMesh(cut);
  EXPECT_GE(cuts, genus);
  EXPECT_EQ(Genus(cut), 0);
  EXPECT_TRUE(topology.closed());
  EXPECT_TRUE(topology.manifold());
  EXPECT_EQ(topology.components, 1);
  EXPECT_GT(topology.volume_m3, 0);
  const double diagonal = GetFixture().truth.Bounds().diagonal().norm();
  const double moved = SymmetricChamferDistance(cut, noisy, 20000);
  std::cout << cuts << " handles cut, surface moved by " << 100 * moved / diagonal << "% of the diagonal\n";
  EXPECT_LT(moved / diagonal, 0.002);

  AtlasStats stats;
  const UvAtlas atlas = BuildAtlas(cut, options, &stats);
  std::cout << "noisy, handles cut, charts merged: " << stats.ToJson().dump() << "\n";
  ExpectValidAtlas(stats, options);
  EXPECT_LT(stats.charts, before.charts);  // handles cut the charts
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
